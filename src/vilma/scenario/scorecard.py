"""The scorecard's definition: its keys, how it is measured (``metrics``) and pass criteria (``expect``).

:mod:`vilma.scenario.metrics` computes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

SCORECARD_KEYS = (
    "completed", "incomplete_reason", "truncated", "sim_time_s", "distance_m", "end_error_m", "path_progress",
    "waypoints_skipped", "lateral_error_rms_m", "lateral_error_max_m", "lateral_error_p95_m", "heading_error_rms_rad",
    "speed_rise_time_90_s", "speed_overshoot_pct", "speed_settling_time_2pct_s", "speed_steady_state_error_mps",
    "speed_error_rms_mps", "steering_rate_rms_radps", "lateral_accel_max_mps2", "longitudinal_jerk_rms_mps3",
    "pose_error_rms_m", "collisions", "goal_reached", "time_to_goal_s", "traffic", "collisions_checked",
    "off_road", "min_distance_to_traffic_m", "min_time_to_collision_s",
    "perception", "planner", "planning_cycles", "planner_fallbacks", "planner_evasions",
    "planner_reason", "mota", "motp_m",
    "detection_precision", "detection_recall", "tracking_position_rmse_m", "tracking_velocity_rmse_mps",
    "identity_switches",
    "wall_time_s", "loop_wall_time_s", "load_time_s", "realtime_factor", "controller_time_per_step_us",
    "planning_ms_mean", "planning_ms_max",
)
"""The keys of ``metrics.json``, in order (see :mod:`vilma.scenario.metrics`; the planning and perception keys of a
``plan`` task: :mod:`vilma.scenario.planned`)."""
TIMING_KEYS = SCORECARD_KEYS[-7:]
"""The keys measured on the wall clock: the only ones two runs of one scenario may differ in."""
BOOLEAN_KEYS = ("completed", "truncated", "goal_reached", "collisions_checked", "off_road")
"""The keys whose values are true or false (``null`` where they do not apply): bounded by equality only."""


@dataclass(frozen=True, slots=True, kw_only=True)
class MetricsSpec:
    """How the scorecard is measured."""

    skip: float = 2.0
    """Path errors and ``speed_error_rms_mps`` are counted after this much sim time from the task's start [s]."""
    settle_band: float = 0.02
    """Settling band of the speed step, a fraction of the target [-]; a speed task is complete only if the car
    ends the run inside it."""
    steady_window: float = 5.0
    """The steady-state speed error is the mean over this last part of the run [s]."""
    end_tolerance: float = 1.0
    """A path or go-to task is complete only if the car stops this close to its end [m]."""
    path_tolerance: float = 2.0
    """The path is covered where the car passes this close to it, in order [m]."""
    min_progress: float = 0.95
    """A path task is complete only if the car covered at least this fraction of the path [-]."""

    def __post_init__(self) -> None:
        if not (self.skip >= 0 and self.settle_band > 0 and self.steady_window > 0):
            raise ValueError("skip must be >= 0 s, settle_band > 0 and steady_window > 0 s")
        if not (self.end_tolerance > 0 and self.path_tolerance > 0 and 0 < self.min_progress <= 1):
            raise ValueError("end_tolerance and path_tolerance must be > 0 m, min_progress in (0, 1]")


@dataclass(frozen=True, slots=True, kw_only=True)
class Bound:
    """A pass criterion on a scorecard value."""

    min: float | None = None
    max: float | None = None

    def check(self, value: Any) -> bool:
        """Whether ``value`` is within the bound (None or NaN never is)."""
        if value is None or isinstance(value, bool) or not math.isfinite(value):
            return False
        return (self.min is None or value >= self.min) and (self.max is None or value <= self.max)
