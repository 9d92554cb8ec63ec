"""Trajectory smoothing: the paper's Algorithm 1 (gradient descent, Gauss-Seidel) and its direct solution.

Algorithm 1 (paper section 4.1; the original's ``generate_smooth_path``):
end points fixed; for i = 1 .. n-2, in place, x then y::

    s_i += alpha (p_i - s_i) + beta (s_{i-1} + s_{i+1} - 2 s_i)

repeated while the sweep's total absolute change is at least ``tolerance``.
Its fixed point solves the tridiagonal system
``(alpha + 2 beta) s_i - beta (s_{i-1} + s_{i+1}) = alpha p_i`` with the
ends fixed, which :func:`smooth_banded` solves directly in O(n).

The update is that system's Gauss-Seidel step relaxed by ``omega = alpha + 2 beta``
(``s_i += omega (gs_i - s_i)``, ``gs_i`` the Gauss-Seidel value), i.e. SOR. The
matrix is symmetric positive definite for alpha > 0, beta >= 0, so the sweeps
converge exactly when 0 < omega < 2 (Ostrowski-Reich; Kahan: omega outside
(0, 2) diverges for any matrix): ``alpha + 2 beta < 2`` (:func:`check_iterative`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from vilma.trajectory.defaults import ALPHA, BETA, TOLERANCE


@njit(cache=True)
def _gauss_seidel(p, s, alpha, beta, tolerance, sum_delta, max_sweeps):
    n = p.shape[0]
    for sweep in range(max_sweeps):
        delta = 0.0
        for i in range(1, n - 1):
            for j in range(2):
                old = s[i, j]
                s[i, j] += alpha * (p[i, j] - s[i, j]) + beta * (s[i - 1, j] + s[i + 1, j] - 2.0 * s[i, j])
                change = abs(s[i, j] - old)
                delta = delta + change if sum_delta else change
        if delta < tolerance:
            return sweep + 1
    return max_sweeps


def check_iterative(alpha: float, beta: float) -> None:
    """Raise ValueError, naming the parameter and its range, unless Algorithm 1's sweeps converge with these weights
    (``alpha + 2 beta < 2``, module docstring); :func:`smooth_banded` solves any alpha > 0, beta >= 0."""
    banded = "lower it, or solve directly: solver banded (--solver banded)"
    if not alpha < 2:
        raise ValueError(f"alpha must be in (0, 2) for the iterative sweeps to converge (alpha + 2 beta < 2), got "
                         f"{alpha:g}; {banded}")
    if not alpha + 2 * beta < 2:
        raise ValueError(f"beta must be in [0, {(2 - alpha) / 2:g}) with alpha {alpha:g} for the iterative sweeps to "
                         f"converge (alpha + 2 beta < 2), got {beta:g}; {banded}")


def smooth_iterative(xy, alpha: float = ALPHA, beta: float = BETA, tolerance: float = TOLERANCE,
                     delta: str = "sum", max_sweeps: int = 1_000_000) -> np.ndarray:
    """Algorithm 1 exactly as the original, in float64 (the original used float32). Returns (n, 2).

    ``delta="sum"`` stops on the sweep's total |change| (the final version);
    ``delta="last"`` on the last y change only (older versions' ``delta =+`` bug, which stops earlier).

    Raises:
        ValueError: weights with which the sweeps diverge (:func:`check_iterative`), or a bad ``delta``.
    """
    if delta not in ("sum", "last"):
        raise ValueError(f"delta must be 'sum' or 'last', got {delta!r}")
    check_iterative(alpha, beta)
    p = _points(xy)
    s = p.copy()
    if len(p) > 2:
        _gauss_seidel(p, s, float(alpha), float(beta), float(tolerance), delta == "sum", int(max_sweeps))
    return s


def smooth_banded(xy, alpha: float = ALPHA, beta: float = BETA) -> np.ndarray:
    """The fixed point of Algorithm 1 solved directly (tridiagonal, O(n)). Returns (n, 2)."""
    p = _points(xy)
    n = len(p)
    if n <= 2:
        return p.copy()
    m = n - 2
    ab = np.zeros((3, m))
    ab[0, 1:] = -beta
    ab[1, :] = alpha + 2.0 * beta
    ab[2, :-1] = -beta
    rhs = alpha * p[1:-1].copy()
    rhs[0] += beta * p[0]
    rhs[-1] += beta * p[-1]
    out = p.copy()
    from scipy.linalg import solve_banded  # 0.1 s to import: only for this solver

    out[1:-1] = solve_banded((1, 1), ab, rhs)
    return out


def _points(xy) -> np.ndarray:
    p = np.array(getattr(xy, "xy", xy), dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(p).all():
        raise ValueError("smoothing needs finite points")
    return p
