"""More points: the original's Generate Points (midpoints) and uniform resampling."""

from __future__ import annotations

import numpy as np

from vilma.trajectory.trajectory import Trajectory


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


def resample(path: Trajectory, spacing: float) -> Trajectory:
    """Points every ``spacing`` [m] of arc length (the last point kept); speeds interpolated."""
    if not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"resample spacing must be a positive number of metres, got {spacing!r}")
    if len(path) < 2 or path.length == 0:
        return path
    s = np.append(np.arange(0.0, path.length, spacing), path.length)
    if s[-1] - s[-2] < 1e-9:
        s = s[:-1]
    xy = np.column_stack([np.interp(s, path.s, path.xy[:, 0]), np.interp(s, path.s, path.xy[:, 1])])
    speed = None if path.speed is None else np.interp(s, path.s, path.speed)
    return Trajectory(xy, speed)
