"""The Frenet frame of a reference path: arc length ``s`` along it, offset ``d`` to its left (Werling et al. 2010).

The reference polyline is interpolated by a cubic spline in arc length (reparametrised once by its own length,
so that the parameter is the arc length to within the spline's tiny speed error); beyond its ends it continues
straight along its end tangents. Conversions are exact for the spline: a point is projected by Newton's method
from the nearest point of the reference polyline (O(points) a projection) onto the spline, and ``P(s) + d n(s)``
gives it back.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.interpolate import CubicSpline

from vilma.trajectory import Trajectory

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(5)


class FrameArrays(NamedTuple):
    """The spline as compiled code reads it: knots (n,) [m], the points there (n, 2) [m] and per-piece
    coefficients (n-1, 4), highest power first."""

    knots: np.ndarray
    xy: np.ndarray
    cx: np.ndarray
    cy: np.ndarray


class FrenetState(NamedTuple):
    """A car's state in the Frenet frame: arc length [m], its rates [m/s, m/s^2], offset left [m] and its rates."""

    s: float
    s_dot: float
    s_ddot: float
    d: float
    d_dot: float = 0.0
    d_ddot: float = 0.0


@njit(cache=True)
def frame_eval(fa, s):
    """Point and first three derivatives with respect to ``s`` [m]: (x, y, x', y', x'', y'', x''', y''')."""
    k = fa.knots
    n = k.shape[0]
    if s < k[0] or s > k[n - 1]:  # straight on along the end tangent
        i, u = (0, 0.0) if s < k[0] else (n - 2, k[n - 1] - k[n - 2])
        cx, cy = fa.cx[i], fa.cy[i]
        x0 = ((cx[0] * u + cx[1]) * u + cx[2]) * u + cx[3]
        y0 = ((cy[0] * u + cy[1]) * u + cy[2]) * u + cy[3]
        tx, ty = (3.0 * cx[0] * u + 2.0 * cx[1]) * u + cx[2], (3.0 * cy[0] * u + 2.0 * cy[1]) * u + cy[2]
        norm = math.hypot(tx, ty)
        tx, ty = tx / norm, ty / norm
        e = s - k[0] if s < k[0] else s - k[n - 1]
        return x0 + e * tx, y0 + e * ty, tx, ty, 0.0, 0.0, 0.0, 0.0
    i = min(max(np.searchsorted(k, s, side="right") - 1, 0), n - 2)
    u = s - k[i]
    cx, cy = fa.cx[i], fa.cy[i]
    return (((cx[0] * u + cx[1]) * u + cx[2]) * u + cx[3], ((cy[0] * u + cy[1]) * u + cy[2]) * u + cy[3],
            (3.0 * cx[0] * u + 2.0 * cx[1]) * u + cx[2], (3.0 * cy[0] * u + 2.0 * cy[1]) * u + cy[2],
            6.0 * cx[0] * u + 2.0 * cx[1], 6.0 * cy[0] * u + 2.0 * cy[1], 6.0 * cx[0], 6.0 * cy[0])


@njit(cache=True)
def frame_pose(fa, s):
    """Reference point, heading [rad], curvature [1/m] and its rate [1/m^2] at ``s`` [m]: (x, y, theta, k, dk)."""
    x, y, dx, dy, ddx, ddy, d3x, d3y = frame_eval(fa, s)
    g = dx * dx + dy * dy
    c = dx * ddy - dy * ddx
    dc = dx * d3y - dy * d3x
    dg = 2.0 * (dx * ddx + dy * ddy)
    return x, y, math.atan2(dy, dx), c / g**1.5, (dc * g - 1.5 * c * dg) / g**2.5


@njit(cache=True)
def _to_cartesian(fa, s, d):
    x, y = np.empty(s.shape[0]), np.empty(s.shape[0])
    for j in range(s.shape[0]):
        px, py, dx, dy, _, _, _, _ = frame_eval(fa, s[j])
        norm = math.hypot(dx, dy)
        x[j], y[j] = px - d[j] * dy / norm, py + d[j] * dx / norm
    return x, y


@njit(cache=True)
def _project(fa, x, y):
    """Arc length of the nearest spline point: the nearest point of the knots' polyline, refined by Newton's
    method on the spline."""
    k = fa.knots
    best, s = np.inf, k[0]
    for i in range(k.shape[0] - 1):
        ax, ay = fa.xy[i, 0], fa.xy[i, 1]
        ex, ey = fa.xy[i + 1, 0] - ax, fa.xy[i + 1, 1] - ay
        f = min(max(((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey), 0.0), 1.0)
        e = (ax + f * ex - x) ** 2 + (ay + f * ey - y) ** 2
        if e < best:
            best, s = e, k[i] + f * (k[i + 1] - k[i])
    for _ in range(50):
        px, py, dx, dy, ddx, ddy, _, _ = frame_eval(fa, s)
        ex, ey = px - x, py - y
        slope = dx * dx + dy * dy + ex * ddx + ey * ddy
        if slope <= 0.0:  # beyond the centre of curvature: the polyline's point is as good as any
            break
        step = (ex * dx + ey * dy) / slope
        s -= step
        if abs(step) < 1e-12:
            break
    return s


@njit(cache=True)
def _to_frenet(fa, x, y):
    s, d = np.empty(x.shape[0]), np.empty(x.shape[0])
    for j in range(x.shape[0]):
        s[j] = _project(fa, x[j], y[j])
        px, py, dx, dy, _, _, _, _ = frame_eval(fa, s[j])
        d[j] = (dx * (y[j] - py) - dy * (x[j] - px)) / math.hypot(dx, dy)
    return s, d


class FrenetFrame:
    """The Frenet frame of a reference path (a :class:`~vilma.trajectory.Trajectory` of two or more points)."""

    def __init__(self, reference: Trajectory) -> None:
        xy = reference.xy[np.concatenate([[True], np.hypot(*np.diff(reference.xy, axis=0).T) > 1e-9])]
        if len(xy) < 2:
            raise ValueError("a Frenet frame needs a reference path of at least two distinct points")
        knots = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        spline = CubicSpline(knots, xy)
        # the chord lengths only approximate the spline's own: refit on its arc length so that s is arc length
        h = np.diff(knots)
        u = knots[:-1, None] + 0.5 * h[:, None] * (_GAUSS_X + 1.0)
        speed = np.hypot(*spline(u, 1).transpose(2, 0, 1))
        spline = CubicSpline(np.concatenate([[0.0], np.cumsum(0.5 * h * (speed @ _GAUSS_W))]), xy)
        c = spline.c  # (4, n-1, 2), highest power first
        self.arrays = FrameArrays(spline.x.copy(), np.ascontiguousarray(xy), np.ascontiguousarray(c[:, :, 0].T),
                                  np.ascontiguousarray(c[:, :, 1].T))

    @property
    def length(self) -> float:
        """Arc length of the reference [m]."""
        return float(self.arrays.knots[-1])

    def to_cartesian(self, s, d) -> tuple[np.ndarray, np.ndarray]:
        """Points ``(x, y)`` [m] at arc lengths ``s`` and left offsets ``d`` [m] (arrays of one shape)."""
        s, d = np.broadcast_arrays(np.asarray(s, dtype=np.float64), np.asarray(d, dtype=np.float64))
        x, y = _to_cartesian(self.arrays, np.ascontiguousarray(s).ravel(), np.ascontiguousarray(d).ravel())
        return x.reshape(s.shape), y.reshape(s.shape)

    def to_frenet(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """Arc lengths ``s`` and left offsets ``d`` [m] of the points ``(x, y)`` [m] (arrays of one shape)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        s, d = _to_frenet(self.arrays, np.ascontiguousarray(x).ravel(), np.ascontiguousarray(y).ravel())
        return s.reshape(x.shape), d.reshape(x.shape)

    def pose(self, s: float) -> tuple[float, float, float, float, float]:
        """Reference ``(x, y, heading, curvature, curvature rate)`` at arc length ``s`` [m, rad, 1/m, 1/m^2]."""
        return tuple(float(v) for v in frame_pose(self.arrays, float(s)))

    def state(self, x: float, y: float, yaw: float, speed: float, accel: float = 0.0,
              curvature: float = 0.0) -> FrenetState:
        """The Frenet state of a car at ``(x, y)`` [m] heading ``yaw`` [rad] at ``speed`` [m/s] with tangential
        ``accel`` [m/s^2] on a path of ``curvature`` [1/m]: the exact inverse of :func:`frenet_motion`."""
        (s,), (d,) = self.to_frenet([x], [y])
        _, _, theta, k, dk = self.pose(s)
        dtheta = yaw - theta
        a_t = accel * math.cos(dtheta) - speed * speed * curvature * math.sin(dtheta)
        a_n = accel * math.sin(dtheta) + speed * speed * curvature * math.cos(dtheta)
        s_dot = speed * math.cos(dtheta) / (1.0 - k * d)
        d_dot = speed * math.sin(dtheta)
        along = (1.0 - k * d) * s_dot
        s_ddot = (a_t + d_dot * k * s_dot + s_dot * (dk * s_dot * d + k * d_dot)) / (1.0 - k * d)
        return FrenetState(float(s), s_dot, s_ddot, float(d), d_dot, a_n - along * k * s_dot)


@njit(cache=True)
def frenet_motion(theta, k, dk, s_dot, s_ddot, d, d_dot, d_ddot):
    """Cartesian motion of a Frenet motion on a reference of heading ``theta``, curvature ``k``, rate ``dk``.

    With the velocity ``A t + B n``, ``A = s_dot (1 - k d)``, ``B = d_dot`` (t, n: the reference's tangent and
    normal) and the acceleration ``(A' - B k s_dot) t + (A k s_dot + B') n``: (yaw [rad], speed [m/s],
    tangential acceleration [m/s^2], curvature [1/m]); at rest the yaw is the reference's and the curvature 0.
    """
    a = s_dot * (1.0 - k * d)
    a_dot = s_ddot * (1.0 - k * d) - s_dot * (dk * s_dot * d + k * d_dot)
    acc_t = a_dot - d_dot * k * s_dot
    acc_n = a * k * s_dot + d_ddot
    v = math.hypot(a, d_dot)
    if v < 1e-6:
        return theta, v, acc_t, 0.0
    return theta + math.atan2(d_dot, a), v, (a * acc_t + d_dot * acc_n) / v, (a * acc_n - d_dot * acc_t) / v**3
