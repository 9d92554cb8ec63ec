import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.trajectory import Trajectory


def _circle(radius=10.0, n=400, arc=math.pi):
    a = np.linspace(0.0, arc, n)
    return Trajectory.from_points(np.column_stack([radius * np.sin(a), radius * (1 - np.cos(a))]))


def test_arc_length_heading_and_curvature_of_a_circle():
    c = _circle(10.0)
    assert c.length == pytest.approx(10.0 * math.pi, rel=1e-4)
    assert c.heading_at(c.length / 2) == pytest.approx(math.pi / 2, abs=1e-3)
    # a left turn of radius 10 m has curvature +0.1 1/m away from the ends (within the polygon's chord error)
    assert c.curvature[50:-50] == pytest.approx(0.1, rel=2e-3)
    assert c.curvature_at(c.length / 2) == pytest.approx(0.1, rel=2e-3)


def test_projection_cross_track_sign_and_progress():
    line = Trajectory.from_points([(0.0, 0.0), (10.0, 0.0), (20.0, 0.0)])
    p = line.project(12.0, 3.0)
    assert (p.index, p.t, p.s, p.cross_track, p.distance_to_end) == pytest.approx((1, 0.2, 12.0, 3.0, 8.0))
    assert line.project(5.0, -2.0).cross_track == pytest.approx(-2.0)
    # before the start and past the end the projection clamps to the ends
    assert line.project(-5.0, 1.0).s == 0.0 and line.project(30.0, 0.0).distance_to_end == 0.0


def test_windowed_projection_agrees_near_the_hint():
    c = _circle(10.0, n=2000)
    full = c.project(3.0, 1.0)
    near = c.project(3.0, 1.0, hint=full.index + 5, window=20)
    assert near == full


@given(st.floats(-50, 50), st.floats(-50, 50))
def test_projection_is_the_nearest_point(x, y):
    c = _circle(10.0, n=200, arc=4.0)
    p = c.project(x, y)
    d = math.hypot(x - p.x, y - p.y)
    dense = np.column_stack([np.interp(np.linspace(0, c.length, 5000), c.s, c.xy[:, i]) for i in range(2)])
    assert d <= np.hypot(dense[:, 0] - x, dense[:, 1] - y).min() + 1e-6
    assert abs(p.cross_track) == pytest.approx(d, abs=1e-9) or p.t in (0.0, 1.0)


@settings(deadline=None)  # the first example loads the compiled projection
@given(st.lists(st.tuples(st.integers(-9, 9), st.integers(-9, 9)), min_size=2, max_size=40),
       st.floats(-12, 12), st.floats(-12, 12), st.integers(0, 40), st.integers(0, 12))
def test_projection_takes_the_first_nearest_segment_of_its_window(points, x, y, hint, window):
    # points on a grid: repeated points, crossings and segments exactly as near as others (ties) are common
    path = Trajectory.from_points(points)
    a, n = path.arrays, len(points) - 1
    hi = min(n, hint + window + 1)
    lo = min(max(0, hint - window), hi - 1)
    # every segment of the window by definition: the clamped foot of the perpendicular, the first of equals
    rx, ry = x - a.xy[:-1, 0], y - a.xy[:-1, 1]
    len2 = a.seg_len * a.seg_len
    t = np.clip(np.where(len2 > 1e-18, (rx * a.seg[:, 0] + ry * a.seg[:, 1]) / np.where(len2 > 1e-18, len2, 1.0),
                         0.0), 0.0, 1.0)
    ex, ey = rx - t * a.seg[:, 0], ry - t * a.seg[:, 1]
    d = ex * ex + ey * ey
    for p, (first, last) in ((path.project(x, y, hint, window), (lo, hi)), (path.project(x, y), (0, n))):
        i = first + int(np.argmin(d[first:last]))
        assert (p.index, p.t) == (i, t[i])


def test_duplicate_points_do_not_make_nan():
    t = Trajectory.from_points([(0, 0), (0, 0), (1, 0), (1, 0), (2, 1)])
    assert np.isfinite(t.heading).all() and np.isfinite(t.curvature).all()
    assert np.isfinite(t.project(0.5, 0.5).cross_track)


def test_speeds_interpolate_and_are_validated():
    t = Trajectory.from_points([(0, 0), (10, 0)], speed=[2.0, 4.0])
    assert t.speed_at(5.0) == pytest.approx(3.0)
    assert Trajectory.from_points([(0, 0), (1, 0)]).speed_at(0.5) is None
    with pytest.raises(ValueError):
        Trajectory.from_points([(0, 0), (1, 0)], speed=[1.0])
    with pytest.raises(ValueError):
        Trajectory.from_points([(0, 0), (math.nan, 0)])
    with pytest.raises(ValueError):
        Trajectory.from_points([])


def test_points_are_read_only():
    t = Trajectory.from_points([(0, 0), (1, 0)])
    with pytest.raises(ValueError):
        t.xy[0, 0] = 5.0
