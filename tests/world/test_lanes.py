"""The lanes prediction follows: the lane a moving object is on, and each way on from there."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vilma.world.lanes import MAX_BRANCHES, Lanes


def _line(x0, y0, x1, y1, n=11):
    return np.column_stack([np.linspace(x0, x1, n), np.linspace(y0, y1, n)])


def _fork() -> Lanes:
    """A lane east from 0 to 20 m (3.5 m wide), forking into one on east to 40 m and one north to y = 20 m; and the
    lane beside the first the other way, west from 20 to 0 m at y = 3.5 m."""
    centres = [_line(0, 0, 20, 0), _line(20, 0, 40, 0), _line(20, 0, 20, 20), _line(20, 3.5, 0, 3.5)]
    return Lanes.of(centres, [np.full(11, 3.5)] * 4, [[1, 2], [], [], []])


def test_an_object_is_on_the_lane_of_its_direction_within_half_its_width():
    lanes = _fork()
    east = lanes.locate(5.2, 1.0, 0.1)
    assert lanes.lane[east] == 0 and lanes.point[east] == 2  # the segment 4-6 m (points every 2 m)
    west = lanes.locate(5.2, 2.5, math.pi)  # nearer the first lane's centre, but moving west: the other lane
    assert lanes.lane[west] == 3
    assert lanes.locate(5.2, 1.0, math.pi / 2) is None  # across both lanes: on neither
    assert lanes.locate(5.2, -1.8, 0.0) is None  # farther than half the lane's width from its centre


def test_the_ways_on_fork_at_the_successors_and_end_within_the_reach():
    lanes = _fork()
    segment = lanes.locate(15.0, 0.0, 0.0)
    short, = lanes.ahead(segment, 4.0)  # the lane's own 4 m past the segment (14-16 m) reach 4 m
    np.testing.assert_allclose(short, _line(0, 0, 20, 0)[lanes.point[segment]:])
    straight, left = lanes.ahead(segment, 30.0)  # the first successor first
    np.testing.assert_allclose(straight[-1], [40.0, 0.0])
    np.testing.assert_allclose(left[-1], [20.0, 20.0])
    for way in (straight, left):  # one polyline on, without the joint's point twice
        assert np.all(np.hypot(*np.diff(way, axis=0).T) > 0)


def test_a_loop_of_lanes_ends_where_it_meets_itself_and_the_ways_are_capped():
    ring = [_line(0, 0, 10, 0), _line(10, 0, 10, 10), _line(10, 10, 0, 10), _line(0, 10, 0, 0)]
    lanes = Lanes.of(ring, [np.full(11, 3.0)] * 4, [[1], [2], [3], [0]])
    way, = lanes.ahead(lanes.locate(1.0, 0.0, 0.0), 1000.0)
    assert way[-1] == pytest.approx([0.0, 0.0]) and len(way) == 41  # once round, then no lane it has not met
    many = Lanes.of([_line(0, 0, 10, 0)] + [_line(10, 0, 20, k) for k in range(6)], [np.full(11, 3.0)] * 7,
                    [list(range(1, 7))] + [[]] * 6)
    assert len(many.ahead(0, 50.0)) == MAX_BRANCHES


def test_from_the_segment_it_was_on_an_object_stays_on_that_lane_while_it_is_on_it():
    lanes = _fork()
    was = lanes.locate(5.0, 0.5, 0.0)
    # on along it, past its end (the successors, which overlap there: the nearest), turned round (the other lane)
    for x, y, heading in ((7.5, 0.5, 0.0), (12.0, -1.0, 0.2), (21.0, 0.3, 0.0), (20.2, 3.0, 1.5), (5.0, 3.5, math.pi)):
        assert lanes.locate(x, y, heading, near=was) == lanes.locate(x, y, heading)
    # past a fork into one lane on east and one 30 degrees left, on the one east it stays on it where the other's
    # centre line is nearer (0.15 m against 0.4 m)
    c, s = math.cos(math.pi / 6), math.sin(math.pi / 6)
    fork = Lanes.of([_line(0, 0, 20, 0), _line(20, 0, 40, 0), _line(20, 0, 20 + 20 * c, 20 * s)],
                    [np.full(11, 3.5)] * 3, [[1, 2], [], []])
    east = fork.locate(22.0, 0.05, 0.0)
    assert fork.lane[east] == 1
    assert fork.lane[fork.locate(21.0, 0.4, 0.3, near=east)] == 1
    assert fork.lane[fork.locate(21.0, 0.4, 0.3)] == 2  # the whole search: the nearest centre line
