import numpy as np
import pytest

from tests.control.conftest import LOGS
from vilma.trajectory import increase_point_count, load_trajectory, smooth_banded, smooth_iterative
from vilma.trajectory.smooth import _gauss_seidel, check_iterative


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


@pytest.mark.parametrize(("alpha", "beta"), [(0.5, 0.1), (1.0, 0.45), (0.2, 0.85), (1.9, 0.0), (0.5, 0.8),
                                             (0.5, 1.0), (1.0, 1.0), (2.5, 0.0)])
def test_the_sweeps_converge_exactly_when_alpha_plus_two_beta_is_below_2(alpha, beta):
    # SOR with omega = alpha + 2 beta on a symmetric positive definite matrix: converges iff 0 < omega < 2
    # (Ostrowski-Reich). Here an error of 1 m shrinks below 1e-6 m in 300 sweeps where they converge (the matrix is
    # tridiagonal: Young's rate, at most omega - 1 = 0.9 a sweep for these weights, 0.9^300 ~ 2e-14) and grows past
    # 1e3 m where they do not (a rate of at least omega - 1 >= 1.1, Kahan: 1.1^300 ~ 3e12)
    xy = _zigzag(30)
    exact, s = smooth_banded(xy, alpha, beta), xy.copy()
    s[1:-1] += 1.0
    _gauss_seidel(xy, s, alpha, beta, 0.0, True, 300)
    error = np.abs(s - exact).max()
    if alpha + 2 * beta < 2:
        assert error < 1e-6
        check_iterative(alpha, beta)
    else:
        assert error > 1e3
        with pytest.raises(ValueError, match=r"^(alpha|beta) must be in"):
            smooth_iterative(xy, alpha, beta)


def test_weights_outside_the_range_name_the_parameter_and_its_range_and_banded_solves_them():
    xy = _zigzag()
    with pytest.raises(ValueError, match=r"^beta must be in \[0, 0.75\) with alpha 0.5 .*got 1; .*--solver banded"):
        smooth_iterative(xy, beta=1.0)
    with pytest.raises(ValueError, match=r"^alpha must be in \(0, 2\) .*got 2;"):
        smooth_iterative(xy, alpha=2.0, beta=0.0)
    assert np.isfinite(smooth_banded(xy, beta=1.0)).all()
