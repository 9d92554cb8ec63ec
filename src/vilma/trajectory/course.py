"""Generated courses: smooth paths through waypoints."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

from vilma.trajectory.trajectory import Trajectory

PAPER_COURSE = ((0.0, 0.0), (100.0, 0.0), (100.0, -30.0), (50.0, -20.0), (60.0, 0.0))
"""The issue's paper-style course [m]: a straight, a hairpin back, and a turn to finish."""


def spline_course(points=PAPER_COURSE, spacing: float = 0.5) -> Trajectory:
    """A C2 natural cubic spline through ``points`` (chord-length parameter), a point every ``spacing`` [m] of chord."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(p) < 2 or not np.isfinite(p).all():
        raise ValueError("a spline course needs at least 2 finite points")
    chords = np.hypot(*np.diff(p, axis=0).T)
    if (chords <= 0).any():
        raise ValueError("a spline course needs distinct consecutive points")
    if not spacing > 0:
        raise ValueError(f"spline course spacing must be > 0 m, got {spacing!r}")
    u = np.concatenate([[0.0], np.cumsum(chords)])
    spline = CubicSpline(u, p, bc_type="natural")
    return Trajectory(spline(np.linspace(0.0, u[-1], max(2, round(u[-1] / spacing) + 1))))
