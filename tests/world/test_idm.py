"""The compiled IDM step's helpers against their definitions: numpy's interp, and the nearest point of a path (the
chunks' bounding boxes only skip segments that cannot be the nearest within reach)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.world.idm import CHUNK, _project, chunk_bounds, interp

finite = st.floats(-100.0, 100.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(0.0, 5.0), min_size=2, max_size=19), st.lists(finite, min_size=20, max_size=20),
       st.floats(-10.0, 110.0))
def test_interp_is_numpys(steps, values, x):
    xp = np.cumsum(steps)  # non-decreasing, with repeats where a step is 0 (a car standing in the recording)
    xp = np.concatenate([xp, xp[-1:]])  # held after the last point, as the paths are
    fp = np.array(values[:len(xp)])
    xs = [x, *xp.tolist()]  # also exactly on the points
    for v in xs:
        assert np.isclose(interp(v, xp, fp), np.interp(v, xp, fp), rtol=1e-12, atol=1e-12 * np.abs(fp).max())


def _nearest(xs: np.ndarray, ys: np.ndarray, px: float, py: float) -> tuple[float, list[float]]:
    """By definition, over every segment: the distance [m] to the path and the arc lengths [m] of its nearest
    points (several where the path comes back within a rounding error of itself)."""
    a, d = np.stack([xs[:-1], ys[:-1]], 1), np.diff(np.stack([xs, ys], 1), axis=0)
    f = np.clip(((np.array([px, py]) - a) * d).sum(1) / np.maximum((d ** 2).sum(1), 1e-12), 0.0, 1.0)
    dist = np.hypot(*(np.array([px, py]) - a - f[:, None] * d).T)
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*d.T))])
    near = dist <= dist.min() + 1e-9
    return float(dist.min()), (arc[:-1] + f * np.hypot(*d.T))[near].tolist()


@settings(max_examples=500, deadline=None)
@given(st.lists(st.tuples(st.floats(-5.0, 5.0), st.floats(-5.0, 5.0)), min_size=CHUNK + 1, max_size=3 * CHUNK + 2),
       st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(-2.5, 2.5), st.floats(-2.5, 2.5))
def test_the_nearest_point_within_reach_is_the_nearest_of_all_segments(moves, where, f, ox, oy):
    xy = np.cumsum(np.array([(0.0, 0.0), *moves]), axis=0)  # a wandering path, zero-length segments included
    xs, ys = xy[:, 0].copy(), xy[:, 1].copy()
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xs), np.diff(ys)))])
    k = min(int(where * (len(xs) - 1)), len(xs) - 2)  # a point near the path: on segment k, moved by (ox, oy)
    px, py = xs[k] + f * (xs[k + 1] - xs[k]) + ox, ys[k] + f * (ys[k + 1] - ys[k]) + oy
    reach = 1.75
    lateral, along = _project(xs, ys, arc, chunk_bounds(xs[None], ys[None])[0], px, py, reach)
    dist, alongs = _nearest(xs, ys, px, py)
    if dist <= reach - 1e-9:
        assert abs(lateral - dist) < 1e-9
        assert min(abs(along - a) for a in alongs) < 1e-9
    elif dist > reach + 1e-9:
        assert lateral > reach
