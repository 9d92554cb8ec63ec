"""Trajectory smoothing: the paper's Algorithm 1 (gradient descent, Gauss-Seidel) and its direct solution.

Algorithm 1 (paper section 4.1; the original's ``generate_smooth_path``):
end points fixed; for i = 1 .. n-2, in place, x then y::

    s_i += alpha (p_i - s_i) + beta (s_{i-1} + s_{i+1} - 2 s_i)

repeated while the sweep's total absolute change is at least ``tolerance``.
Its fixed point solves the tridiagonal system
``(alpha + 2 beta) s_i - beta (s_{i-1} + s_{i+1}) = alpha p_i`` with the
ends fixed, which :func:`smooth_banded` solves directly in O(n).
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


def smooth_iterative(xy, alpha: float = ALPHA, beta: float = BETA, tolerance: float = TOLERANCE,
                     delta: str = "sum", max_sweeps: int = 1_000_000) -> np.ndarray:
    """Algorithm 1 exactly as the original, in float64 (the original used float32). Returns (n, 2).

    ``delta="sum"`` stops on the sweep's total |change| (the final version);
    ``delta="last"`` on the last y change only (older versions' ``delta =+`` bug, which stops earlier).
    """
    if delta not in ("sum", "last"):
        raise ValueError(f"delta must be 'sum' or 'last', got {delta!r}")
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
