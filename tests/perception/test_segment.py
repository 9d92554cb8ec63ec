"""Segmentation against geometry: each box its own cluster, a wall split exactly where the adaptive breakpoint
criterion says (Borges & Aldon 2004), and the clusters always a partition of the returns."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.perception.conftest import SICK, boxes, scan
from vilma.perception.segment import SegmentParams, scan_points, segment
from vilma.sensors.scene import Scene
from vilma.vehicle.state import VehicleState

MOUNT = SICK.position[0]  # the laser ahead of the car's centre of mass [m]
BEARINGS = SICK.bearings


def on_box(points: np.ndarray, centre, yaw: float, size) -> np.ndarray:
    """Whether each point (n, 2) lies on the outline of the box (within 1e-4 m, the ranges being float32)."""
    c, s = math.cos(yaw), math.sin(yaw)
    d = np.nan_to_num(points - centre, nan=1e9)  # no return: on no box
    u, v = np.abs(d @ [c, s]), np.abs(d @ [-s, c])
    half = np.array(size) / 2
    return (u <= half[0] + 1e-4) & (v <= half[1] + 1e-4) & ((u >= half[0] - 1e-4) | (v >= half[1] - 1e-4))


def test_each_box_is_one_cluster_holding_exactly_the_rays_that_hit_it():
    centres = np.array([[12.0, 0.0], [12.0, 5.0], [20.0, -6.0], [6.0, -4.0]])  # in the laser frame
    yaws, sizes = [0.3, 0.0, -1.0, 1.2], [(4.5, 1.8), (4.5, 1.8), (10.0, 2.5), (0.6, 0.6)]
    scene = boxes([[(x + MOUNT, y, a)] for (x, y), a in zip(centres, yaws, strict=True)], sizes)
    ranges = scan(scene)
    points = scan_points(ranges, BEARINGS)
    clusters = segment(ranges, BEARINGS, SegmentParams(range_noise=0.0))
    hits = [set(np.flatnonzero(on_box(points, c, a, s)).tolist()) for c, a, s in zip(centres, yaws, sizes, strict=True)]
    assert all(hits) and sorted((set(c.tolist()) for c in clusters), key=min) == sorted(hits, key=min)


def test_a_wall_is_split_exactly_where_the_beams_meet_it_at_less_than_lambda():
    """Beams at bearing phi meet a wall parallel to x at angle phi: by the law of sines in the triangle laser,
    point n-1, point n, the points are r sin(dphi) / sin(phi - dphi) apart, more than the allowed
    r sin(dphi) / sin(lambda - dphi) exactly when phi < lambda (with no range noise)."""
    lam, side = math.radians(10.0), 3.0
    ranges = scan(boxes([[(MOUNT + 35.0, side + 0.5, 0.0)]], [(70.0, 1.0)]))
    params = SegmentParams(angle=lam, range_noise=0.0)
    (cluster,) = segment(ranges, BEARINGS, params)
    wall = np.flatnonzero(np.isfinite(ranges))
    steep = wall[BEARINGS[wall] > lam + math.radians(0.3)]  # the breakpoint may fall within a ray of lambda
    shallow = wall[BEARINGS[wall] < lam - math.radians(0.3)]
    assert set(steep.tolist()) <= set(cluster.tolist()) and not set(shallow.tolist()) & set(cluster.tolist())
    assert len(shallow) > 20 and len(segment(ranges, BEARINGS, SegmentParams(angle=lam, range_noise=0.0,
                                                                            min_points=1))) == len(shallow) + 1


def test_rays_without_a_return_split_and_small_clusters_are_dropped():
    ranges = np.full(len(BEARINGS), np.inf)
    assert segment(ranges, BEARINGS) == []
    ranges[100:110] = 5.0
    ranges[103] = np.nan  # no return: the ray went through between its neighbours' points
    ranges[500:502] = 5.0  # two returns: fewer than min_points = 3
    ranges[600:604] = [5.0, 5.0, np.inf, 5.0]
    (a, b) = segment(ranges, BEARINGS)
    assert (a.tolist(), b.tolist()) == ([100, 101, 102], list(range(104, 110)))
    assert [c.tolist() for c in segment(ranges, BEARINGS, SegmentParams(min_points=2))][2:] == [[500, 501], [600, 601]]


def test_objects_with_only_empty_rays_between_them_are_two_clusters():
    """Two boxes far apart in depth, 8 deg apart in bearing with nothing between: not one surface."""
    ranges = scan(boxes([[(MOUNT + 10.0, 0.0, 0.0)], [(MOUNT + 25.0, -5.0, 0.0)]], [(1.0, 1.0), (4.5, 1.8)]))
    assert len(segment(ranges, BEARINGS)) == 2


@pytest.mark.parametrize(("ranges", "bearings", "match"), [
    (np.ones(3), np.arange(4.0), "as many ranges as bearings"),
    (np.ones(3), np.array([0.0, 0.2, 0.1]), "increasing"),
    (np.array([1.0, -1.0, 1.0]), np.arange(3.0), "ranges must be >= 0"),
])
def test_bad_scans_are_refused_in_one_line(ranges, bearings, match):
    with pytest.raises(ValueError, match=match) as e:
        segment(ranges, bearings)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(("field", "value"), [("angle", 0.0), ("angle", math.pi), ("range_noise", -0.1),
                                              ("min_points", 0)])
def test_bad_params_are_refused(field, value):
    with pytest.raises(ValueError, match=field):
        SegmentParams(**{field: value})


def partition(ranges: np.ndarray, bearings: np.ndarray, min_points: int) -> None:
    """Assert that the clusters are disjoint runs of neighbouring rays with returns, in scan order, each of
    ``min_points`` or more, and with ``min_points`` 1 cover every return."""
    clusters = segment(ranges, bearings, SegmentParams(min_points=min_points))
    returns = np.flatnonzero(np.isfinite(ranges))
    flat = np.concatenate([np.zeros(0, np.int64), *clusters])
    assert (np.diff(flat) > 0).all() and set(flat.tolist()) <= set(returns.tolist())
    assert all(len(c) >= min_points for c in clusters)
    assert all((np.diff(c) == 1).all() for c in clusters)
    if min_points == 1:
        assert flat.tolist() == returns.tolist()


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(-30, 30), st.floats(-30, 30), st.floats(-math.pi, math.pi),
                          st.floats(0.1, 12), st.floats(0.1, 4)), max_size=6),
       st.floats(0, 0.2), st.integers(1, 5))
def test_random_boxes_never_crash_and_the_clusters_partition_the_returns(placed, noise, min_points):
    scene = boxes([[(x, y, a)] for x, y, a, _, _ in placed], [(length, w) for *_, length, w in placed]) if placed \
        else Scene.of(None)
    partition(scan(scene, VehicleState(), laser=dataclasses.replace(SICK, range_noise=noise)), BEARINGS, min_points)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.one_of(st.floats(0, 100), st.just(math.inf), st.just(math.nan)), max_size=200),
       st.integers(1, 5))
def test_any_ranges_never_crash_and_the_clusters_partition_the_returns(ranges, min_points):
    partition(np.array(ranges, float), np.linspace(-1.0, 1.0, len(ranges)), min_points)


@settings(max_examples=150, deadline=None)
@given(st.floats(0, 30), st.lists(st.one_of(st.floats(-0.5, 0.5), st.just(math.inf), st.just(math.nan)), max_size=120),
       st.floats(0.005, 0.3), st.floats(math.radians(1.0), math.radians(60.0)), st.floats(0, 0.5),
       st.integers(1, 4))
def test_the_clusters_are_the_runs_that_borges_and_aldons_criterion_joins(first, steps, step, lam, noise, min_points):
    """Each pair of neighbouring rays, checked alone by eq. 4 (points at most r sin(dphi) / sin(lambda - dphi) +
    3 sigma apart, rays less than lambda apart, both with a return), joins or splits the clusters, exactly. The
    returns wander from ``first`` [m] by ``steps`` (surfaces at many angles; inf, NaN: no return)."""
    ranges, last = [first], first
    for d in steps:
        last = max(0.0, last + d) if math.isfinite(d) else last
        ranges.append(last if math.isfinite(d) else d)
    b = step * np.arange(len(ranges))

    def joined(n: int) -> bool:  # rays n - 1 and n
        r0, r1, dphi = ranges[n - 1], ranges[n], b[n] - b[n - 1]
        if not (dphi < lam and math.isfinite(r0) and math.isfinite(r1)):
            return False
        gap = np.hypot(r1 * math.cos(b[n]) - r0 * math.cos(b[n - 1]), r1 * math.sin(b[n]) - r0 * math.sin(b[n - 1]))
        return gap <= r0 * math.sin(dphi) / math.sin(lam - dphi) + 3 * noise

    runs, run = [], []
    for n, r in enumerate(ranges):
        if n and not joined(n):
            runs, run = [*runs, run], []
        run += [n] if math.isfinite(r) else []
    expected = [k for k in [*runs, run] if len(k) >= min_points]
    params = SegmentParams(angle=lam, range_noise=noise, min_points=min_points)
    assert [c.tolist() for c in segment(np.array(ranges), b, params)] == expected
