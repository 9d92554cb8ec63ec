"""Speed profiles: what speed a car can hold along a path."""

from __future__ import annotations

import numpy as np

from vilma.trajectory.trajectory import Trajectory


def speed_profile(path: Trajectory, speed: float | None, max_lateral_accel: float, max_decel: float) -> Trajectory:
    """The path with speeds limited by curvature and by braking ahead of each limit.

    Each point's speed is the set ``speed`` (or the path's own), at most
    ``sqrt(a_lat / |kappa|)`` [m/s], and low enough to brake at ``max_decel``
    [m/s^2] to every slower point ahead (a backward pass).
    """
    if speed is None and path.speed is None:
        raise ValueError("speed profile: give a speed or a path with speeds")
    base = np.full(len(path), float(speed)) if speed is not None else np.array(path.speed)
    k = np.abs(path.curvature)
    v = np.minimum(base, np.sqrt(max_lateral_accel / np.maximum(k, 1e-12)))
    ds = np.diff(path.s)
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], np.sqrt(v[i + 1] ** 2 + 2.0 * max_decel * ds[i]))
    return Trajectory(path.xy, v)
