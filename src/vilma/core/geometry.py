"""Angles and frames.

World frame is ENU: x east, y north, z up. Yaw is counter-clockwise from +x
and wrapped to (-pi, pi]. Body frame: x forward, y left, z up.

The original VILMA code measured heading from +y (its car pointed along +y at
yaw 0): :func:`heading_from_north_ccw` and :func:`yaw_from_heading_north_ccw`
are the one place that converts.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


def wrap_angle(a):
    """Wrap an angle [rad] (scalar or array) to (-pi, pi]."""
    w = np.mod(np.asarray(a, dtype=float) + math.pi, 2.0 * math.pi) - math.pi
    w = np.where(w <= -math.pi, w + 2.0 * math.pi, w)
    return float(w) if np.ndim(w) == 0 else w


@njit(cache=True)
def wrap(a: float) -> float:
    """Compiled scalar :func:`wrap_angle`: angle [rad] to (-pi, pi]."""
    w = (a + math.pi) % (2.0 * math.pi) - math.pi
    return w + 2.0 * math.pi if w <= -math.pi else w


def quaternion_from_euler(roll, pitch, yaw):
    """ZYX Euler angles [rad] -> quaternion ``(x, y, z, w)`` (arrays broadcast)."""
    cr, sr = np.cos(np.multiply(roll, 0.5)), np.sin(np.multiply(roll, 0.5))
    cp, sp = np.cos(np.multiply(pitch, 0.5)), np.sin(np.multiply(pitch, 0.5))
    cy, sy = np.cos(np.multiply(yaw, 0.5)), np.sin(np.multiply(yaw, 0.5))
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def yaw_from_quaternion(x, y, z, w):
    """Yaw [rad] of a quaternion (ZYX convention)."""
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def heading_from_north_ccw(yaw):
    """ENU yaw [rad] -> the original's heading (from +y, counter-clockwise) [rad]."""
    return wrap_angle(np.asarray(yaw) - math.pi / 2.0)


def yaw_from_heading_north_ccw(heading):
    """The original's heading (from +y, counter-clockwise) [rad] -> ENU yaw [rad]."""
    return wrap_angle(np.asarray(heading) + math.pi / 2.0)
