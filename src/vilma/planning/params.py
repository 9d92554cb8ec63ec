"""The local planner's parameters: sampling, costs and limits (:class:`PlannerParams`)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from vilma.core.checks import check_numbers
from vilma.core.messages import MAX_PATH_POINTS
from vilma.vehicle.params import VehicleParams, vilma

MAX_CANDIDATES = 4000
"""Most candidates a cycle may sample (lateral times longitudinal samples)."""
MAX_STEPS = MAX_PATH_POINTS - 1
"""Most time steps in a horizon: its points (one more) fit a bus message."""
GRAVITY = 9.81
"""[m/s^2]"""
EVASIVE_SPACING = 0.5
"""The evasive manoeuvres' end offsets are the lateral offsets and every this many metres between their extremes [m]."""

@dataclass(frozen=True, slots=True, kw_only=True)
class PlannerParams:
    """Sampling, costs and limits of the planner. Times [s], lengths [m], speeds [m/s], accelerations [m/s^2]."""

    vehicle: VehicleParams = vilma()
    """The car: its box (length, width, body offset), steering limit and acceleration limits."""
    horizon: float = 3.0
    """Length of the planned trajectory [s]."""
    dt: float = 0.1
    """Time step of the trajectory and of the predicted objects [s]; the horizon is a whole number of them."""
    replan_period: float = 0.2
    """Time between planning cycles [s], a whole number of ``dt``."""
    lateral_offsets: tuple[float, ...] = (-3.5, -1.0, 0.0, 1.0, 3.5)
    """End offsets from the reference [m], left positive (the neighbour lanes' centres among them)."""
    lateral_durations: tuple[float, ...] = (1.5, 2.0, 2.5, 3.0)
    """Durations of the lateral manoeuvres [s]."""
    target_speed: float = 10.0
    """Desired speed of velocity keeping [m/s]."""
    speed_offsets: tuple[float, ...] = (-2.0, -1.0, 0.0, 1.0)
    """End speeds sampled around the target speed [m/s] (each limited to what the comfortable accelerations
    reach within the duration); besides, one braking hard for each duration."""
    speed_durations: tuple[float, ...] = (1.5, 2.25, 3.0)
    """Durations of the velocity-keeping quartics [s]."""
    position_offsets: tuple[float, ...] = (-3.0, -2.0, -1.0, -0.5, 0.0)
    """End positions sampled at and behind a following or stopping target [m], each <= 0 (never closer to a lead
    than the gap, never past the goal)."""
    position_durations: tuple[float, ...] = (2.0, 3.0, 4.5, 6.0, 8.0)
    """Durations of the following and stopping quintics [s] (those past the horizon are planned whole and
    driven for the horizon); one more is the time a steady slow-down to the target's speed takes to reach it."""
    follow_distance: float = 5.0
    """Werling's ``d0``: the gap to a lead at rest [m], bumper to bumper."""
    time_gap: float = 1.5
    """Werling's ``tau``: the gap grows by this time times the lead's speed [s]."""
    lane_width: float = 3.5
    """An object is a lead when its centre is less than half this from the car's offset [m] and ahead."""
    max_lateral_accel: float = 6.0
    """Most lateral acceleration a candidate may ask for [m/s^2]: an evasive manoeuvre well within the tyres'
    grip (friction 1: 9.8 m/s^2), where the path controller still tracks it."""
    evasive_grip: float = 0.95
    """Fraction of the tyres' grip (friction x g) an evasive manoeuvre may ask for as lateral acceleration [-]. Only
    when no candidate is free and even the emergency stop collides does the planner sample these: the end offsets
    of :attr:`evasive_offsets`, at this limit, without :attr:`margin`; 0 never swerves beyond
    :attr:`max_lateral_accel`."""
    comfort_accel: float = 2.0
    """Acceleration a velocity-keeping end speed is planned with at most [m/s^2]."""
    margin: float = 0.2
    """Added to each side of the car's box in the collision check and against the road's edges [m]."""
    jerk_weight: float = 0.1
    """Werling's ``k_j``: weight of the integral of the squared jerk [s^5/m^2]."""
    time_weight: float = 1.0
    """``k_t``: weight of a manoeuvre's duration [1/s]."""
    offset_weight: float = 1.0
    """``k_d``: weight of the squared end offset from the reference [1/m^2]."""
    deviation_weight: float = 8.0
    """Weight of the mean squared offset from the reference over the horizon [1/m^2] (beyond Werling's costs):
    so that the car comes back to the reference soon once past an obstacle, not at the slow pace that costs
    least in jerk and time."""
    speed_weight: float = 1.0
    """``k_v``: weight of the squared miss of the target speed [s^2/m^2]."""
    position_weight: float = 1.0
    """``k_s``: weight of the squared miss of a following or stopping target [1/m^2]."""
    lateral_weight: float = 1.0
    """``k_lat``: weight of the lateral cost in the total."""
    longitudinal_weight: float = 1.0
    """``k_lon``: weight of the longitudinal cost in the total."""

    def __post_init__(self) -> None:
        samples = ("lateral_offsets", "lateral_durations", "speed_offsets", "speed_durations", "position_offsets",
                   "position_durations")
        for name in samples:
            if len(getattr(self, name)) == 0:
                raise ValueError(f"planner {name} is empty; give at least one value")
        check_numbers(self, "planner", positive=("horizon", "dt", "replan_period", "lateral_durations",
                                                 "speed_durations", "position_durations", "lane_width",
                                                 "comfort_accel", "max_lateral_accel"))
        for name in ("target_speed", "follow_distance", "time_gap", "margin", "jerk_weight", "time_weight",
                     "deviation_weight",
                     "offset_weight", "speed_weight", "position_weight", "lateral_weight", "longitudinal_weight"):
            if getattr(self, name) < 0:
                raise ValueError(f"planner {name} must be >= 0, got {getattr(self, name)!r}")
        for name in ("horizon", "replan_period"):
            steps = getattr(self, name) / self.dt
            if abs(steps - round(steps)) > 1e-9:
                raise ValueError(f"planner {name} {getattr(self, name)!r} s is not a whole number of dt "
                                 f"{self.dt!r} s; make it one")
        if self.steps > MAX_STEPS:
            raise ValueError(f"planner horizon / dt is {self.steps} steps, over the limit of {MAX_STEPS}; "
                             "raise dt or shorten the horizon")
        if max(self.position_offsets) > 0:
            raise ValueError(f"planner position_offsets must be <= 0 m (at or behind the target), got "
                             f"{self.position_offsets!r}")
        if self.replan_period > self.horizon:
            raise ValueError(f"planner replan_period {self.replan_period!r} s is longer than the horizon "
                             f"{self.horizon!r} s; shorten it")
        if not 0.0 <= self.evasive_grip <= 1.0:
            raise ValueError(f"planner evasive_grip must be within 0 .. 1 (a fraction of the tyres' grip), got "
                             f"{self.evasive_grip!r}")
        if self.candidate_count > MAX_CANDIDATES:
            evasive = (f" (the evasive tier's end offsets are every {EVASIVE_SPACING:g} m between the extreme lateral "
                       "offsets: narrow them, or set evasive_grip: 0)") if self.evasive_grip > 0 else ""
            raise ValueError(f"planner samples {self.candidate_count} candidates, over the limit of "
                             f"{MAX_CANDIDATES}; sample fewer offsets, speeds or durations{evasive}")

    @property
    def steps(self) -> int:
        """Time steps in the horizon (the trajectory has one point more)."""
        return round(self.horizon / self.dt)

    @property
    def times(self) -> np.ndarray:
        """The trajectory's times, 0 .. horizon [s] (steps + 1,): the times the predicted objects are given at."""
        return np.arange(self.steps + 1) * self.dt

    @property
    def evasive_offsets(self) -> tuple[float, ...]:
        """End offsets of the evasive manoeuvres [m]: the lateral offsets and every :data:`EVASIVE_SPACING` between
        their extremes."""
        lo, hi = min(self.lateral_offsets), max(self.lateral_offsets)
        grid = lo + EVASIVE_SPACING * np.arange(math.floor((hi - lo) / EVASIVE_SPACING) + 1)
        return tuple(sorted({*self.lateral_offsets, *grid.tolist()}))

    @property
    def evasive(self) -> PlannerParams:
        """The parameters of the evasive manoeuvres (:attr:`evasive_grip`)."""
        return replace(self, lateral_offsets=self.evasive_offsets, margin=0.0, evasive_grip=0.0,
                       max_lateral_accel=self.evasive_grip * self.vehicle.friction * GRAVITY)

    @property
    def candidate_count(self) -> int:
        """Most candidates a cycle evaluates (in its evasive tier, if it swerves)."""
        offsets = len(self.evasive_offsets) if self.evasive_grip > 0 else len(self.lateral_offsets)
        lateral = offsets * len(self.lateral_durations)
        return lateral * max((len(self.speed_offsets) + 1) * len(self.speed_durations),
                             len(self.position_offsets) * (len(self.position_durations) + 1))

    @property
    def max_curvature(self) -> float:
        """Curvature of the car's tightest turn [1/m]: tan(max steer) / wheelbase."""
        return math.tan(self.vehicle.max_steer) / self.vehicle.wheelbase
