"""Trajectories: the type, files, the original's smoothing and point tools, resampling, speed profiles, recording.

The names below load their module on first use (PEP 562), so that a light module of the package (the command
line's defaults) does not import numba and scipy.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

_MODULES = {
    "points": ("densify", "increase_point_count", "resample"),
    "io": ("TrajectoryFileError", "check_trajectory_file", "load_trajectory", "save_trajectory"),
    "profile": ("Arrival", "arrival_profile", "speed_profile"),
    "recorder": ("SpeedRecorder", "TrajectoryRecorder", "load_speed_log"),
    "smooth": ("smooth_banded", "smooth_iterative"),
    "trajectory": ("Projection", "Trajectory"),
}
_WHERE = {name: module for module, names in _MODULES.items() for name in names}
__all__ = sorted(_WHERE)

if TYPE_CHECKING:  # the names for type checkers (F401: __all__ is computed)
    from vilma.trajectory.io import TrajectoryFileError, check_trajectory_file, load_trajectory, save_trajectory  # noqa: F401
    from vilma.trajectory.points import densify, increase_point_count, resample  # noqa: F401
    from vilma.trajectory.profile import Arrival, arrival_profile, speed_profile  # noqa: F401
    from vilma.trajectory.recorder import SpeedRecorder, TrajectoryRecorder, load_speed_log  # noqa: F401
    from vilma.trajectory.smooth import smooth_banded, smooth_iterative  # noqa: F401
    from vilma.trajectory.trajectory import Projection, Trajectory  # noqa: F401


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'vilma.trajectory' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"vilma.trajectory.{_WHERE[name]}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return __all__
