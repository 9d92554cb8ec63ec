"""The self-driver (the paper's ``VilmaSelfDriver``): modes, controller scheduling and the final stop.

Modes as the original GUI offers them: manual (no commands), set speed,
hold the current speed, go to a point, follow a trajectory from its first
point to its end and stop there at rest. The speed and path controllers
run at their own periods (each a whole multiple of the physics step,
checked); :meth:`Driver.update` is called every :attr:`Driver.period` with
the sensor readings of that period and returns the command to send.

The final approach is the driver's, not the speed controller's (the
original's PID cannot brake): once the remaining distance is what braking
at ``stop_deceleration`` needs, the driver brakes to stop on the last point
and then holds the brake.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from vilma.control.path import (
    PathController,
    PurePursuit,
    PurePursuitParams,
    Stanley,
    StanleyParams,
    VilmaHeading,
    VilmaHeadingParams,
)
from vilma.control.speed import LongitudinalOutput, PiFf, PiFfParams, SpeedController, VilmaPid, VilmaPidParams
from vilma.core.clock import Clock, seconds_to_ns
from vilma.core.messages import ActuatorCommand, DriverStatus, Longitudinal, PoseEstimate
from vilma.localization import make_estimator
from vilma.sensors import Readings
from vilma.trajectory import Trajectory, speed_profile
from vilma.vehicle.params import VehicleParams

SPEED_CONTROLLERS = ("vilma_pid", "pi_ff")
PATH_CONTROLLERS = ("vilma_heading", "pure_pursuit", "stanley")


class DriverMode(StrEnum):
    """What the self-driver is doing."""

    MANUAL = "manual"
    SET_SPEED = "set_speed"
    HOLD_SPEED = "hold_speed"
    GO_TO_POINT = "go_to_point"
    FOLLOW = "follow"


@dataclass(frozen=True, slots=True, kw_only=True)
class DriverParams:
    """Which controllers the driver uses, their parameters, and how it measures and stops."""

    speed_controller: str = "pi_ff"
    """One of :data:`SPEED_CONTROLLERS`."""
    path_controller: str = "stanley"
    """One of :data:`PATH_CONTROLLERS`."""
    pose_source: str = "truth"
    """``truth`` (the simulator's exact pose) or ``ekf`` (fused GPS, IMU and wheel speeds)."""
    vilma_pid: VilmaPidParams = VilmaPidParams()
    pi_ff: PiFfParams = PiFfParams()
    vilma_heading: VilmaHeadingParams = VilmaHeadingParams()
    pure_pursuit: PurePursuitParams = PurePursuitParams()
    stanley: StanleyParams = StanleyParams()
    original_speed: bool = False
    """Measure speed as the original: sqrt(vx^2 + vy^2 + wz^2), world-frame velocity plus the yaw rate (a bug)."""
    actuation_delay: bool = False
    """Send each speed command one speed period after computing it, as the original's sleep-then-send."""
    stop_deceleration: float = 2.0
    """Braking of the final approach and ahead of curves [m/s^2]."""
    max_lateral_accel: float = 2.0
    """Lateral acceleration the speed profile allows in curves [m/s^2]."""
    rest_speed: float = 0.05
    """Below this speed [m/s] the car is at rest."""

    def __post_init__(self) -> None:
        for name, value, known in (("speed_controller", self.speed_controller, SPEED_CONTROLLERS),
                                   ("path_controller", self.path_controller, PATH_CONTROLLERS),
                                   ("pose_source", self.pose_source, ("truth", "ekf"))):
            if value not in known:
                raise ValueError(f"driver {name} {value!r} is unknown; use one of {', '.join(known)}")
        if not self.stop_deceleration > 0:
            raise ValueError(f"driver stop_deceleration must be > 0 m/s^2, got {self.stop_deceleration!r}")

    @classmethod
    def original(cls) -> DriverParams:
        """The shipped program: its PID with its quirks, Turn-Wheels with its quirks, its speed formula and delay."""
        return cls(speed_controller="vilma_pid", path_controller="vilma_heading",
                   vilma_pid=VilmaPidParams.original(), vilma_heading=VilmaHeadingParams(original_quirks=True),
                   original_speed=True, actuation_delay=True)


def make_speed_controller(params: DriverParams, vehicle: VehicleParams) -> SpeedController:
    """The configured speed controller."""
    return VilmaPid(params.vilma_pid) if params.speed_controller == "vilma_pid" else PiFf(vehicle, params.pi_ff)


def make_path_controller(params: DriverParams, vehicle: VehicleParams) -> PathController:
    """The configured path controller."""
    if params.path_controller == "vilma_heading":
        return VilmaHeading(params.vilma_heading)
    if params.path_controller == "pure_pursuit":
        return PurePursuit(vehicle, params.pure_pursuit)
    return Stanley(vehicle, params.stanley)


@dataclass(slots=True)
class _Task:
    mode: DriverMode = DriverMode.MANUAL
    speed: float = 0.0
    path: Trajectory | None = None
    arrived: bool = False
    stopping: bool = False
    error: str = ""


class Driver:
    """The self-driver of one car.

    Args:
        vehicle: the car's parameters (feed-forward, geometry).
        params: controllers and options.
        step: the simulator's physics step [s]; every period must be a whole multiple of it.
    """

    def __init__(self, vehicle: VehicleParams, params: DriverParams | None = None, step: float = 0.01) -> None:
        self.vehicle, self.params = vehicle, params or DriverParams()
        self.speed_ctrl = make_speed_controller(self.params, vehicle)
        self.path_ctrl = make_path_controller(self.params, vehicle)
        clock = Clock(seconds_to_ns(step))
        self.speed_ticks = clock.period_ticks(1.0 / self.speed_ctrl.period, f"{self.params.speed_controller} period")
        self.path_ticks = clock.period_ticks(1.0 / self.path_ctrl.period, f"{self.params.path_controller} period")
        self.period_ticks = math.gcd(self.speed_ticks, self.path_ticks)
        self.period = self.period_ticks * clock.step_s
        self.estimator = make_estimator(self.params.pose_source, vehicle)
        self.task = _Task()
        self._ticks = 0
        self._stamp_ns = 0
        self._pose: PoseEstimate | None = None
        self._speed = 0.0
        self._steer = 0.0
        self._long = LongitudinalOutput(Longitudinal.FORCE, 0.0)
        self._pending: LongitudinalOutput | None = None
        self._progress: tuple[int, float, float, float] | None = None

    # -- orders ------------------------------------------------------------------------------------------

    def manual(self) -> None:
        """Stop commanding; the car keeps its last command (as the original's setManualControl)."""
        self._start(_Task(DriverMode.MANUAL))

    def set_speed(self, speed: float) -> None:
        """Hold ``speed`` [m/s] straight ahead."""
        self._start(_Task(DriverMode.SET_SPEED, speed=_finite(speed, "speed")))

    def hold_current_speed(self) -> None:
        """Hold the speed measured now (truncated to an integer with the original's quirks)."""
        v = self._speed
        if self.params.speed_controller == "vilma_pid" and self.params.vilma_pid.integer_target:
            v = float(math.trunc(v))
        self._start(_Task(DriverMode.HOLD_SPEED, speed=v))

    def go_to(self, x: float, y: float, speed: float) -> None:
        """Drive to the point ``(x, y)`` [m] at ``speed`` [m/s] and stop on it."""
        x, y, speed = _finite(x, "x"), _finite(y, "y"), _finite(speed, "speed")
        start = (self._pose.x, self._pose.y) if self._pose else (0.0, 0.0)
        if math.hypot(x - start[0], y - start[1]) < 1e-6:
            raise ValueError("go to point: the car is already at that point")
        self._start(_Task(DriverMode.GO_TO_POINT, speed=speed, path=Trajectory.from_points([start, (x, y)])))

    def follow(self, path: Trajectory, speed: float | None = None) -> None:
        """Follow ``path`` from its first point to its end and stop there.

        Speed: ``speed`` [m/s] if given, else the path's own speeds (an error if it has none),
        lowered where curves need it (:func:`~vilma.trajectory.speed_profile`).
        """
        if speed is None and path.speed is None:
            raise ValueError("follow: the trajectory has no speeds; give a speed")
        if len(path) < 2:
            raise ValueError("follow: the trajectory needs at least 2 points")
        speed = None if speed is None else _finite(speed, "speed")
        profiled = speed_profile(path, speed, self.params.max_lateral_accel, self.params.stop_deceleration)
        self._start(_Task(DriverMode.FOLLOW, speed=math.nan, path=profiled))

    def _start(self, task: _Task) -> None:
        self.task = task
        self.speed_ctrl.reset()
        self.path_ctrl.reset()
        self._pending = None
        self._progress = None
        self._ticks = 0

    # -- the loop ----------------------------------------------------------------------------------------

    def update(self, readings: dict[str, Readings]) -> ActuatorCommand | None:
        """Take one period's readings; returns the command to send now, or None in manual mode."""
        pose = self.estimator.update(readings)
        if pose is not None:
            self._pose, self._stamp_ns = pose, pose.stamp_ns
            self._speed = self._measured_speed(readings, pose)
        task = self.task
        run_speed = self._ticks % self.speed_ticks == 0
        run_path = self._ticks % self.path_ticks == 0
        self._ticks += self.period_ticks
        if task.mode == DriverMode.MANUAL or self._pose is None:
            return None
        if task.path is not None:
            if run_path:
                out = self.path_ctrl.step(self._pose, task.path)
                self._steer = out.steer
                task.stopping |= out.done  # the controller ran out of path (Turn-Wheels passed the last point)
            self._track(task)
        else:
            self._steer = 0.0
        if task.stopping or task.arrived:
            self._long = self._final_stop(task)
        elif run_speed:
            computed = self.speed_ctrl.step(self._target_speed(task), self._speed, self._steer)
            if self.params.actuation_delay:
                self._long, self._pending = self._pending or LongitudinalOutput(Longitudinal.POWER, 0.0), computed
            else:
                self._long = computed
        o = self._long
        return ActuatorCommand(stamp_ns=self._stamp_ns, steer=self._steer, longitudinal=o.mode, drive=o.drive,
                               brake=o.brake, velocity_limit=o.velocity_limit, autonomous=True)

    def _measured_speed(self, readings: dict[str, Readings], pose: PoseEstimate) -> float:
        vel = readings.get("velocity")
        if self.params.original_speed and vel is not None and len(vel):
            m = vel.latest()
            return math.sqrt(m.vx_world**2 + m.vy_world**2 + m.wz**2)
        return pose.speed

    def _track(self, task: _Task) -> None:
        """Progress along the path and the switch to the final stop."""
        path = task.path
        hint = self._progress[0] if self._progress else None
        proj = path.project(self._pose.x, self._pose.y, hint=hint, window=40 if hint is not None else None)
        self._progress = (proj.index, proj.s, proj.distance_to_end, proj.cross_track)
        braking = self._speed**2 / (2.0 * self.params.stop_deceleration)
        if not task.stopping and proj.distance_to_end <= braking + self._speed * self.period:
            task.stopping = True

    def _target_speed(self, task: _Task) -> float:
        if task.mode == DriverMode.FOLLOW and math.isnan(task.speed):
            return float(task.path.speed_at(self._progress[1] if self._progress else 0.0))
        return task.speed

    def _final_stop(self, task: _Task) -> LongitudinalOutput:
        """Brake to stop on the last point: deceleration v^2 / (2 d), then hold."""
        v, d = self._speed, max(self._progress[2], 0.05)
        if task.arrived or abs(v) < self.params.rest_speed:
            task.arrived = True
            decel = self.params.stop_deceleration
        else:
            decel = min(v * v / (2.0 * d), 2.0 * self.params.stop_deceleration)
        return LongitudinalOutput(Longitudinal.FORCE, 0.0, brake=self.vehicle.mass * decel)

    @property
    def status(self) -> DriverStatus:
        """What the driver is doing, for the ``driver/status`` topic."""
        t = self.task
        index, progress, remaining, cross = self._progress or (0, 0.0, 0.0, math.nan)
        target = self._target_speed(t) if t.mode != DriverMode.MANUAL else 0.0
        return DriverStatus(self._stamp_ns, t.mode.value, float(target), float(self._speed), int(index),
                            float(progress), float(remaining), float(cross), t.arrived, t.error)


def _finite(v: float, name: str) -> float:
    v = float(v)
    if not np.isfinite(v):
        raise ValueError(f"driver order: {name} must be a finite number, got {v!r}")
    return v
