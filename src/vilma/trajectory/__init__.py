"""Trajectories: the type, files, the original's smoothing and point tools, resampling, recording."""

from vilma.trajectory.densify import densify, increase_point_count, resample
from vilma.trajectory.io import TrajectoryFileError, check_trajectory_file, load_trajectory, save_trajectory
from vilma.trajectory.profile import Arrival, arrival_profile, speed_profile
from vilma.trajectory.recorder import SpeedRecorder, TrajectoryRecorder, load_speed_log
from vilma.trajectory.smooth import smooth_banded, smooth_iterative
from vilma.trajectory.trajectory import Projection, Trajectory

__all__ = ["Arrival", "Projection", "SpeedRecorder", "Trajectory", "TrajectoryFileError", "TrajectoryRecorder",
           "arrival_profile", "check_trajectory_file", "densify", "increase_point_count", "load_speed_log",
           "load_trajectory", "resample", "save_trajectory", "smooth_banded", "smooth_iterative", "speed_profile"]
