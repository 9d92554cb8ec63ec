"""Quintic and quartic polynomials from boundary conditions (Werling et al. 2010), evaluated with derivatives.

A polynomial is its six coefficients ``c0 .. c5`` of ``x(t) = sum c_i t^i`` (a quartic has ``c5 = 0``), over
``0 <= t <= T``; every function takes arrays that broadcast, one polynomial per element.
"""

from __future__ import annotations

import numpy as np
from numba import njit


def _start(x0, v0, a0, T):
    x0, v0, a0, T = (np.asarray(v, dtype=np.float64) for v in (x0, v0, a0, T))
    if not (T > 0).all():
        raise ValueError(f"a polynomial's duration must be > 0 s, got {T.min()!r}")
    return x0, v0, a0, T


def _coefficients(*columns) -> np.ndarray:
    """The coefficients (..., 6) of columns that broadcast (filled in place: stacking broadcast copies costs a
    planning cycle more than the arithmetic)."""
    out = np.empty((*np.broadcast_shapes(*(np.shape(c) for c in columns)), 6))
    for k, c in enumerate(columns):
        out[..., k] = c
    return out


def quintic(x0, v0, a0, x1, v1, a1, T) -> np.ndarray:
    """Coefficients (..., 6) of the quintic from ``x, x', x''`` = ``(x0, v0, a0)`` at 0 to ``(x1, v1, a1)`` at ``T``.

    The three conditions at ``T`` solved for ``c3, c4, c5`` in closed form (the minimum-jerk motion between them).
    """
    x0, v0, a0, T = _start(x0, v0, a0, T)
    h = x1 - x0 - v0 * T - 0.5 * a0 * T**2  # what c3, c4, c5 add to the value at T
    p = v1 - v0 - a0 * T  # to the rate
    q = a1 - a0  # to the second derivative
    c3 = (10.0 * h - 4.0 * p * T + 0.5 * q * T**2) / T**3
    c4 = (-15.0 * h + 7.0 * p * T - q * T**2) / T**4
    c5 = (6.0 * h - 3.0 * p * T + 0.5 * q * T**2) / T**5
    return _coefficients(x0, v0, 0.5 * a0, c3, c4, c5)


def quartic(x0, v0, a0, v1, a1, T) -> np.ndarray:
    """Coefficients (..., 6) of the quartic from ``(x0, v0, a0)`` at 0 to rate ``v1`` and ``a1`` at ``T``
    (velocity keeping: the end position is free)."""
    x0, v0, a0, T = _start(x0, v0, a0, T)
    p = v1 - v0 - a0 * T  # what c3 and c4 add to the rate at T
    q = a1 - a0  # and to the second derivative
    c3 = (3.0 * p - q * T) / (3.0 * T**2)
    c4 = (q * T - 2.0 * p) / (4.0 * T**3)
    return _coefficients(x0, v0, 0.5 * a0, c3, c4, 0.0)


def evaluate(coeffs, T, t) -> np.ndarray:
    """Value and first three derivatives (4, ..., n_t) of polynomials ``coeffs`` (..., 6) at times ``t`` (n_t,) [s].

    Past its duration ``T`` (...) a polynomial goes on at its end rate (its end second derivative taken as 0, as
    every end state here has it): the held lane offset, the kept speed.
    """
    c = np.asarray(coeffs, dtype=np.float64)
    T = np.broadcast_to(np.asarray(T, dtype=np.float64), c.shape[:-1])
    t = np.ascontiguousarray(t, dtype=np.float64)
    out = _evaluate(np.ascontiguousarray(c).reshape(-1, 6), np.ascontiguousarray(T).ravel(), t)
    return out.reshape(4, *c.shape[:-1], len(t))


@njit(cache=True)
def _evaluate(c, T, t):
    """:func:`evaluate` of polynomials (n, 6) with durations (n,): (4, n, n_t)."""
    out = np.empty((4, c.shape[0], t.shape[0]))
    for i in range(c.shape[0]):
        c0, c1, c2, c3, c4, c5 = c[i, 0], c[i, 1], c[i, 2], c[i, 3], c[i, 4], c[i, 5]
        for k in range(t.shape[0]):
            tau = min(t[k], T[i])
            x = ((((c5 * tau + c4) * tau + c3) * tau + c2) * tau + c1) * tau + c0
            v = (((5.0 * c5 * tau + 4.0 * c4) * tau + 3.0 * c3) * tau + 2.0 * c2) * tau + c1
            after = t[k] > T[i]
            out[0, i, k] = x + v * (t[k] - tau)
            out[1, i, k] = v
            out[2, i, k] = 0.0 if after else ((20.0 * c5 * tau + 12.0 * c4) * tau + 6.0 * c3) * tau + 2.0 * c2
            out[3, i, k] = 0.0 if after else (60.0 * c5 * tau + 24.0 * c4) * tau + 6.0 * c3
    return out


def jerk_cost(coeffs, T) -> np.ndarray:
    """The integral of the squared third derivative over ``0 .. T`` (...), exact: with jerk ``p + q t + r t^2``,
    ``p^2 T + p q T^2 + (q^2 + 2 p r) T^3 / 3 + q r T^4 / 2 + r^2 T^5 / 5``."""
    c = np.asarray(coeffs, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    p, q, r = 6.0 * c[..., 3], 24.0 * c[..., 4], 60.0 * c[..., 5]
    return p * p * T + p * q * T**2 + (q * q + 2.0 * p * r) * T**3 / 3.0 + q * r * T**4 / 2.0 + r * r * T**5 / 5.0


_POWERS = np.array([3.0, 4.0, 5.0])[:, None]


def to_rest(x0: float, v0: float, a0: float, x1: np.ndarray | None, v1: np.ndarray, T: np.ndarray):
    """Coefficients (n, 6) and :func:`jerk_cost` (n,) of the polynomials from ``(x0, v0, a0)`` at 0 to rate ``v1``
    (n,) and no acceleration at ``T`` (n,) [s]: quartics (``x1`` None) or quintics to ``x1`` (n,); the values of
    :func:`quartic`, :func:`quintic` and :func:`jerk_cost` bit for bit, in one compiled call (numpy's powers)."""
    T = np.asarray(T, dtype=np.float64)
    if not (T > 0).all():
        raise ValueError(f"a polynomial's duration must be > 0 s, got {T.min()!r}")
    quintics = x1 is not None
    return _to_rest(x0, v0, a0, x1 if quintics else T, np.asarray(v1, dtype=np.float64), T, T**_POWERS, quintics)


@njit(cache=True)
def _to_rest(x0, v0, a0, x1, v1, T, powers, quintics):
    """:func:`to_rest` with ``powers`` (3, n): ``T`` to the 3rd, 4th and 5th."""
    coeffs, cost = np.empty((T.shape[0], 6)), np.empty(T.shape[0])
    q = 0.0 - a0
    for n in range(T.shape[0]):
        t, t2, t3, t4, t5 = T[n], T[n] * T[n], powers[0, n], powers[1, n], powers[2, n]
        p = v1[n] - v0 - a0 * t
        c5 = 0.0
        if quintics:  # the expressions of quintic() and quartic(), in their order
            h = x1[n] - x0 - v0 * t - 0.5 * a0 * t2
            c3 = (10.0 * h - 4.0 * p * t + 0.5 * q * t2) / t3
            c4 = (-15.0 * h + 7.0 * p * t - q * t2) / t4
            c5 = (6.0 * h - 3.0 * p * t + 0.5 * q * t2) / t5
        else:
            c3 = (3.0 * p - q * t) / (3.0 * t2)
            c4 = (q * t - 2.0 * p) / (4.0 * t3)
        coeffs[n, 0], coeffs[n, 1], coeffs[n, 2], coeffs[n, 3], coeffs[n, 4] = x0, v0, 0.5 * a0, c3, c4
        coeffs[n, 5] = c5
        j0, j1, j2 = 6.0 * c3, 24.0 * c4, 60.0 * c5
        cost[n] = (j0 * j0 * t + j0 * j1 * t2 + (j1 * j1 + 2.0 * j0 * j2) * t3 / 3.0 + j1 * j2 * t4 / 2.0
                   + j2 * j2 * t5 / 5.0)
    return coeffs, cost
