"""Generated courses: smooth paths through waypoints, kept on disk once made."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

from vilma.core.caches import can_write, private_folder
from vilma.core.files import atomic_path
from vilma.trajectory.trajectory import Trajectory

PAPER_COURSE = ((0.0, 0.0), (100.0, 0.0), (100.0, -30.0), (50.0, -20.0), (60.0, 0.0))
"""The issue's paper-style course [m]: a straight, a hairpin back, and a turn to finish."""


def spline_course(points=PAPER_COURSE, spacing: float = 0.5) -> Trajectory:
    """A C2 natural cubic spline through ``points`` (chord-length parameter), a point every ``spacing`` [m] of chord."""
    from scipy.interpolate import CubicSpline  # 0.3-0.5 s to import: only when the course is not on disk

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


def cache_dir() -> Path:
    """Where vilma keeps what it made once [folder]: ``$VILMA_CACHE_DIR``, else ``$XDG_CACHE_HOME/vilma`` (by
    default ``~/.cache/vilma``); where that cannot be written (a user without a home, or a read-only one), a folder
    of this user's alone in the temporary directory (:func:`~vilma.core.caches.private_folder`)."""
    root = os.environ.get("VILMA_CACHE_DIR")
    if root:
        return Path(root)
    try:
        folder = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "vilma"
    except RuntimeError:  # no home at all (a user id without an entry in the password database)
        folder = None
    if folder is not None and can_write(str(folder)):
        return folder
    try:
        return Path(private_folder("vilma-cache"))
    except OSError:
        return folder or Path(os.devnull)  # (nothing is kept: course() makes the course again each time)


def course(points=PAPER_COURSE, spacing: float = 0.5) -> Trajectory:
    """:func:`spline_course`, its points read from the cache folder (:func:`cache_dir`) when this vilma and scipy
    made it before: importing scipy.interpolate takes longer than a whole drive of the course. The same bits either
    way; a cache file that cannot be read or written is made again or skipped, never an error."""
    import scipy

    from vilma import __version__

    p = np.asarray(points, dtype=float).reshape(-1, 2)
    key = hashlib.sha256(repr((p.tolist(), float(spacing), __version__, scipy.__version__)).encode()).hexdigest()
    file = cache_dir() / "courses" / f"{key[:32]}.npy"
    try:
        xy = np.load(file, allow_pickle=False)
        if xy.dtype == np.float64 and xy.ndim == 2 and xy.shape[1] == 2 and len(xy) >= 2 and np.isfinite(xy).all():
            return Trajectory(xy)
    except (OSError, ValueError, EOFError):
        pass  # not made yet, or unreadable: made again
    path = spline_course(p, spacing)
    try:
        file.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(file) as tmp, open(tmp, "wb") as f:
            np.save(f, path.xy)
    except OSError:
        pass  # a read-only or full disk: the next run makes it again
    return path
