import numpy as np
import pytest

from tests.control.conftest import LOGS
from vilma.trajectory import increase_point_count, load_trajectory, smooth_banded, smooth_iterative


def _zigzag(n=60, seed=0):
    rng = np.random.default_rng(seed)
    return np.column_stack([np.arange(n, dtype=float), rng.normal(0, 1, n)])


def test_banded_reaches_the_iterative_fixed_point():
    for xy in (_zigzag(), increase_point_count(load_trajectory(LOGS / "PositionLog_curved.txt")).xy):
        assert np.abs(smooth_banded(xy) - smooth_iterative(xy)).max() < 1e-4


def test_ends_fixed_and_straight_evenly_spaced_lines_are_fixed_points():
    xy = _zigzag()
    s = smooth_banded(xy)
    assert np.array_equal(s[[0, -1]], xy[[0, -1]])
    line = np.column_stack([np.linspace(0, 10, 11), np.linspace(0, 5, 11)])
    assert np.allclose(smooth_iterative(line), line) and np.allclose(smooth_banded(line), line)


def test_smoothing_reduces_roughness():
    xy = _zigzag()
    rough = lambda p: float(np.sum(np.diff(p, 2, axis=0) ** 2))  # noqa: E731
    # the fixed point is a low-pass filter with gain alpha / (alpha + 2 beta (1 - cos w)): 1 at w = 0,
    # 0.5 / 0.9 at the Nyquist frequency, so roughness (second differences) shrinks, but by at most that squared
    ratio = rough(smooth_banded(xy)) / rough(xy)
    assert (0.5 / 0.9) ** 2 < ratio < 1.0


def test_fixed_point_equation_holds():
    xy = _zigzag()
    s = smooth_banded(xy, alpha=0.5, beta=0.1)
    # interior: alpha (p - s) + beta (s[i-1] + s[i+1] - 2 s) = 0  (the update of Algorithm 1 is zero)
    r = 0.5 * (xy[1:-1] - s[1:-1]) + 0.1 * (s[:-2] + s[2:] - 2 * s[1:-1])
    assert np.abs(r).max() < 1e-12


def test_last_change_stopping_rule_stops_earlier():
    xy = _zigzag(200)
    full, old = smooth_iterative(xy), smooth_iterative(xy, delta="last")
    exact = smooth_banded(xy)
    assert np.abs(old - exact).max() >= np.abs(full - exact).max()
    with pytest.raises(ValueError):
        smooth_iterative(xy, delta="first")
