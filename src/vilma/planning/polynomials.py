"""Quintic and quartic polynomials from boundary conditions (Werling et al. 2010), evaluated with derivatives.

A polynomial is its six coefficients ``c0 .. c5`` of ``x(t) = sum c_i t^i`` (a quartic has ``c5 = 0``), over
``0 <= t <= T``; every function takes arrays that broadcast, one polynomial per element.
"""

from __future__ import annotations

import numpy as np


def _start(x0, v0, a0, T):
    x0, v0, a0, T = np.broadcast_arrays(*(np.asarray(v, dtype=np.float64) for v in (x0, v0, a0, T)))
    if not (T > 0).all():
        raise ValueError(f"a polynomial's duration must be > 0 s, got {T.min()!r}")
    return x0, v0, a0, T


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
    return np.stack(np.broadcast_arrays(x0, v0, 0.5 * a0, c3, c4, c5), axis=-1)


def quartic(x0, v0, a0, v1, a1, T) -> np.ndarray:
    """Coefficients (..., 6) of the quartic from ``(x0, v0, a0)`` at 0 to rate ``v1`` and ``a1`` at ``T``
    (velocity keeping: the end position is free)."""
    x0, v0, a0, T = _start(x0, v0, a0, T)
    p = v1 - v0 - a0 * T  # what c3 and c4 add to the rate at T
    q = a1 - a0  # and to the second derivative
    c3 = (3.0 * p - q * T) / (3.0 * T**2)
    c4 = (q * T - 2.0 * p) / (4.0 * T**3)
    return np.stack(np.broadcast_arrays(x0, v0, 0.5 * a0, c3, c4, np.zeros_like(x0)), axis=-1)


def evaluate(coeffs, T, t) -> np.ndarray:
    """Value and first three derivatives (4, ..., n_t) of polynomials ``coeffs`` (..., 6) at times ``t`` (n_t,) [s].

    Past its duration ``T`` (...) a polynomial goes on at its end rate (its end second derivative taken as 0, as
    every end state here has it): the held lane offset, the kept speed.
    """
    c = np.asarray(coeffs, dtype=np.float64)[..., None, :]
    T = np.asarray(T, dtype=np.float64)[..., None]
    t = np.asarray(t, dtype=np.float64)
    tau = np.minimum(t, T)
    x = ((((c[..., 5] * tau + c[..., 4]) * tau + c[..., 3]) * tau + c[..., 2]) * tau + c[..., 1]) * tau + c[..., 0]
    v = (((5.0 * c[..., 5] * tau + 4.0 * c[..., 4]) * tau + 3.0 * c[..., 3]) * tau + 2.0 * c[..., 2]) * tau + c[..., 1]
    a = ((20.0 * c[..., 5] * tau + 12.0 * c[..., 4]) * tau + 6.0 * c[..., 3]) * tau + 2.0 * c[..., 2]
    j = (60.0 * c[..., 5] * tau + 24.0 * c[..., 4]) * tau + 6.0 * c[..., 3]
    after = t > T
    return np.stack([x + v * (t - tau), v, np.where(after, 0.0, a), np.where(after, 0.0, j)])


def jerk_cost(coeffs, T) -> np.ndarray:
    """The integral of the squared third derivative over ``0 .. T`` (...), exact: with jerk ``p + q t + r t^2``,
    ``p^2 T + p q T^2 + (q^2 + 2 p r) T^3 / 3 + q r T^4 / 2 + r^2 T^5 / 5``."""
    c = np.asarray(coeffs, dtype=np.float64)
    T = np.asarray(T, dtype=np.float64)
    p, q, r = 6.0 * c[..., 3], 24.0 * c[..., 4], 60.0 * c[..., 5]
    return p * p * T + p * q * T**2 + (q * q + 2.0 * p * r) * T**3 / 3.0 + q * r * T**4 / 2.0 + r * r * T**5 / 5.0
