"""More points: the original's Generate Points (midpoints) and uniform resampling."""

from __future__ import annotations

import math

import numpy as np

from vilma.trajectory.trajectory import Trajectory

MAX_POINTS = 1_000_000
"""Most points :func:`densify` and :func:`resample` make: a point every centimetre over 10 km."""
MAX_DENSIFY = MAX_POINTS.bit_length() - 1
"""Most Generate Points passes on any path: the next one would take even 2 points past :data:`MAX_POINTS`."""


def increase_point_count(path: Trajectory) -> Trajectory:
    """Insert the midpoint between each consecutive pair, n -> 2n-1, as the original's Generate Points."""
    if len(path) < 2:
        raise ValueError("Generate Points needs at least 2 points")

    def interleave(a: np.ndarray) -> np.ndarray:
        out = np.empty((2 * len(a) - 1, *a.shape[1:]))
        out[0::2] = a
        out[1::2] = 0.5 * (a[:-1] + a[1:])
        return out

    return Trajectory(interleave(path.xy), None if path.speed is None else interleave(path.speed))


def densify(path: Trajectory, times: int) -> Trajectory:
    """:func:`increase_point_count` ``times`` times; ValueError, before any work, if that makes more than
    :data:`MAX_POINTS` points."""
    n = len(path)
    if n > 1 and (times > MAX_DENSIFY or (n - 1) << times >= MAX_POINTS):  # n -> (n - 1) 2^times + 1
        raise ValueError(f"densifying {n} points {times} times makes more than {MAX_POINTS} points, the limit of a "
                         "path; densify fewer times")
    for _ in range(times):
        path = increase_point_count(path)
    return path


def resample(path: Trajectory, spacing: float) -> Trajectory:
    """Points every ``spacing`` [m] of arc length (the last point kept); speeds interpolated."""
    if not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"resample spacing must be a positive number of metres, got {spacing!r}")
    if len(path) < 2 or path.length == 0:
        return path
    if path.length / spacing > MAX_POINTS - 1:  # ceil(length / spacing) + 1 points
        need = path.length / (MAX_POINTS - 1)
        scale = 10.0 ** (2 - math.floor(math.log10(need)))  # rounded up to 3 digits: enough, as said
        raise ValueError(f"resampling {path.length:.1f} m every {spacing:g} m makes more than {MAX_POINTS} points, "
                         f"the limit of a path; use a spacing of at least {math.ceil(need * scale) / scale:g} m")
    s = np.append(np.arange(0.0, path.length, spacing), path.length)
    if s[-1] - s[-2] < 1e-9:
        s = s[:-1]
    xy = np.column_stack([np.interp(s, path.s, path.xy[:, 0]), np.interp(s, path.s, path.xy[:, 1])])
    speed = None if path.speed is None else np.interp(s, path.s, path.speed)
    return Trajectory(xy, speed)
