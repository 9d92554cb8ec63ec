"""Predicted futures by kinematics: straight on at constant velocity, or at constant velocity in a lane's frame
(along its centreline and across it)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vilma.perception.prediction import predict
from vilma.perception.tracker import Track
from vilma.trajectory import Trajectory

TIMES = np.linspace(0.0, 3.0, 31)


def track(x=0.0, y=0.0, yaw=0.0, vx=0.0, vy=0.0, length=4.5, width=1.8) -> Track:
    return Track(1, x, y, yaw, vx, vy, length, width, np.eye(4), 1.0)


def test_without_a_lane_a_track_goes_straight_on_at_its_velocity():
    (got,) = predict([track(2.0, -1.0, 0.5, 3.0, 4.0)], TIMES)
    np.testing.assert_allclose(got[:, 0], 2.0 + 3.0 * TIMES)
    np.testing.assert_allclose(got[:, 1], -1.0 + 4.0 * TIMES)
    assert (got[:, 2] == 0.5).all() and (got[:, 3:] == [4.5, 1.8]).all()


def test_along_a_corner_the_track_turns_with_the_lane_at_its_speed_and_keeps_its_offset():
    """A lane east 20 m then north; a track 0.5 m left of it at x = 10 m, 5 m/s along it: after t it is 5 t m on
    along the lane, on the second leg (x = 20 - 0.5) from the corner on (5 t >= 10 m: a vertex takes the heading of
    the segment leaving it), heading north."""
    lane = Trajectory([[0.0, 0.0], [20.0, 0.0], [20.0, 30.0]])
    (got,) = predict([track(10.0, 0.5, 0.1, 5.0, 0.0)], TIMES, [lane])
    s = 10.0 + 5.0 * TIMES
    first, second = s < 20.0, s >= 20.0
    np.testing.assert_allclose(got[first, :3], np.column_stack([s[first], np.full(first.sum(), 0.5),
                                                                 np.zeros(first.sum())]), atol=1e-12)
    np.testing.assert_allclose(got[second, :3], np.column_stack([np.full(second.sum(), 19.5), s[second] - 20.0,
                                                                  np.full(second.sum(), math.pi / 2)]), atol=1e-12)


def test_a_track_moving_across_its_lane_keeps_its_velocity_in_the_lanes_frame():
    """A lane changer (a cut-in): 4 m/s along the lane east and 1 m/s across it to the left, from 0.5 m left of it
    at x = 10 m: its offset grows by 1 m/s while it moves on at 4 m/s, facing its motion."""
    lane = Trajectory([[0.0, 0.0], [50.0, 0.0]])
    (got,) = predict([track(10.0, 0.5, 0.0, 4.0, 1.0)], TIMES, [lane])
    np.testing.assert_allclose(got[:, :3], np.column_stack([10.0 + 4.0 * TIMES, 0.5 + 1.0 * TIMES,
                                                            np.full(len(TIMES), math.atan2(1.0, 4.0))]), atol=1e-12)


def test_against_the_lane_the_track_goes_backwards_along_it_and_faces_back():
    lane = Trajectory([[0.0, 0.0], [50.0, 0.0]])
    (got,) = predict([track(30.0, -1.0, math.pi, -10.0, 0.0)], TIMES, [lane])
    np.testing.assert_allclose(got[:, :2], np.column_stack([30.0 - 10.0 * TIMES, np.full(len(TIMES), -1.0)]))
    np.testing.assert_allclose(np.abs(got[:, 2]), math.pi)


def test_past_the_lanes_end_the_track_goes_straight_on():
    lane = Trajectory([[0.0, 0.0], [0.0, 10.0]])  # north, 10 m
    (got,) = predict([track(0.0, 8.0, math.pi / 2, 0.0, 4.0)], TIMES, [lane])
    np.testing.assert_allclose(got[:, :2], np.column_stack([np.zeros(len(TIMES)), 8.0 + 4.0 * TIMES]), atol=1e-12)


def test_lanes_only_for_some_tracks():
    lane = Trajectory([[0.0, 0.0], [0.0, 10.0]])
    got = predict([track(vx=1.0), track(vy=1.0)], [0.0, 2.0], [None, lane])
    assert got.shape == (2, 2, 5) and got[0, 1, 0] == 2.0 and got[1, 1, 1] == 2.0


@pytest.mark.parametrize(("times", "lanes", "match"), [
    ([-1.0], None, "times must be finite"),
    ([1.0], [None, None], "one lane"),
    ([1.0], [Trajectory([[1.0, 1.0]])], "two distinct points"),
])
def test_bad_input_is_refused_in_one_line(times, lanes, match):
    with pytest.raises(ValueError, match=match):
        predict([track()], times, lanes)
