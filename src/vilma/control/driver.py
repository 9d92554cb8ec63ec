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
from typing import NamedTuple

import numpy as np
from numba import njit

from vilma.control.path import (
    PathController,
    PurePursuit,
    PurePursuitParams,
    Stanley,
    StanleyParams,
    VilmaHeading,
    VilmaHeadingParams,
)
from vilma.control.path.pure_pursuit import pure_pursuit_step
from vilma.control.path.stanley import stanley_step
from vilma.control.path.vilma_heading import vilma_heading_step
from vilma.control.speed import PiFf, PiFfParams, SpeedController, VilmaPid, VilmaPidParams
from vilma.control.speed.pi_ff import pi_ff_step
from vilma.control.speed.vilma_pid import vilma_pid_step
from vilma.core.clock import Clock, seconds_to_ns
from vilma.core.messages import ActuatorCommand, DriverStatus, PoseEstimate
from vilma.localization import make_estimator
from vilma.sensors import Readings
from vilma.trajectory import Trajectory, speed_profile
from vilma.trajectory.trajectory import path_project, path_speed_at
from vilma.vehicle.actuators import FORCE, MODE_IDS, POWER
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


MODES = tuple(DriverMode)
"""Mode ids of the compiled driver: the index in this tuple."""
MANUAL, FOLLOW = MODES.index(DriverMode.MANUAL), MODES.index(DriverMode.FOLLOW)
LONGITUDINAL = {v: k for k, v in MODE_IDS.items()}
"""Compiled longitudinal mode id -> :class:`Longitudinal`."""

(TICKS, MODE, SPEED, STOPPING, ARRIVED, HAS_POSE, X, Y, YAW, POSE_SPEED, YAW_RATE, MEASURED, STEER,
 L_MODE, L_DRIVE, L_BRAKE, L_LIMIT, HAS_PENDING, P_MODE, P_DRIVE, P_BRAKE, P_LIMIT,
 HAS_PROGRESS, INDEX, PROGRESS, REMAINING, CROSS) = range(27)
"""Slots of the driver's state array: ticks since the order, mode id, ordered speed [m/s] (NaN: the path's),
final stop under way, arrived, pose known and the pose (x, y [m], yaw [rad], speed [m/s], yaw rate [rad/s]),
measured speed [m/s], steering [rad], the longitudinal command (mode id, drive, brake, velocity limit),
the one held back by the actuation delay, and the progress on the path (segment, s, left [m], cross-track [m])."""
N_STATE = 27

PROGRESS_WINDOW = 40
"""Segments searched on each side of the last projection when tracking progress."""


class DriverConsts(NamedTuple):
    """The driver's parameters as compiled code reads them."""

    speed_id: int
    """Index in :data:`SPEED_CONTROLLERS`."""
    path_id: int
    """Index in :data:`PATH_CONTROLLERS`."""
    speed_ticks: int
    path_ticks: int
    period_ticks: int
    period: float
    actuation_delay: bool
    stop_deceleration: float
    rest_speed: float
    mass: float
    velocity_amount: float


@njit(cache=True)
def target_speed(ds, pa):
    """The speed the driver aims at now [m/s]: ordered, or the path's at the progress made."""
    if ds[MODE] == FOLLOW and math.isnan(ds[SPEED]):
        return path_speed_at(pa, ds[PROGRESS] if ds[HAS_PROGRESS] else 0.0)
    return ds[SPEED]


@njit(cache=True)
def _track(dc, ds, pa):
    """Progress along the path and the switch to the final stop."""
    hint = int(ds[INDEX]) if ds[HAS_PROGRESS] else -1
    i, _, s, cross, _, _, _, left = path_project(pa, ds[X], ds[Y], hint, PROGRESS_WINDOW)
    ds[HAS_PROGRESS], ds[INDEX], ds[PROGRESS], ds[REMAINING], ds[CROSS] = 1.0, i, s, left, cross
    v = ds[MEASURED]
    braking = v * v / (2.0 * dc.stop_deceleration)
    if not ds[STOPPING] and left <= braking + v * dc.period:
        ds[STOPPING] = 1.0


@njit(cache=True)
def _final_stop(dc, ds):
    """Brake to stop on the last point: deceleration v^2 / (2 d), then hold."""
    v, d = ds[MEASURED], max(ds[REMAINING], 0.05)
    if ds[ARRIVED] or abs(v) < dc.rest_speed:
        ds[ARRIVED] = 1.0
        decel = dc.stop_deceleration
    else:
        decel = min(v * v / (2.0 * d), 2.0 * dc.stop_deceleration)
    ds[L_MODE], ds[L_DRIVE], ds[L_BRAKE], ds[L_LIMIT] = FORCE, 0.0, dc.mass * decel, math.inf


@njit(cache=True)
def driver_step(dc, ds, pa, has_path, vp, pf, speed_state, vh, pp, st, path_state):
    """One driver period on the pose and measured speed already in ``ds``; True if it commands.

    ``vp``, ``pf``, ``vh``, ``pp``, ``st`` are the five controllers' constants; ``speed_state`` and
    ``path_state`` the state arrays of the two in use. The command is left in ``ds`` (STEER, L_*).
    """
    ticks = int(ds[TICKS])
    run_speed = ticks % dc.speed_ticks == 0
    run_path = ticks % dc.path_ticks == 0
    ds[TICKS] = ticks + dc.period_ticks
    if ds[MODE] == MANUAL or not ds[HAS_POSE]:
        return False
    if has_path:
        if run_path:
            if dc.path_id == 0:
                steer, _, _, done = vilma_heading_step(vh, path_state, pa, ds[X], ds[Y], ds[YAW])
                if done:  # Turn-Wheels passed the last point
                    ds[STOPPING] = 1.0
            elif dc.path_id == 1:
                steer, _, _ = pure_pursuit_step(pp, path_state, pa, ds[X], ds[Y], ds[YAW], ds[POSE_SPEED])
            else:
                steer, _, _ = stanley_step(st, path_state, pa, ds[X], ds[Y], ds[YAW], ds[POSE_SPEED], ds[YAW_RATE])
            ds[STEER] = steer
        _track(dc, ds, pa)
    else:
        ds[STEER] = 0.0
    if ds[STOPPING] or ds[ARRIVED]:
        _final_stop(dc, ds)
    elif run_speed:
        target = target_speed(ds, pa)
        if dc.speed_id == 0:
            mode, drive, brake, limit = POWER, vilma_pid_step(vp, speed_state, target, ds[MEASURED], ds[STEER]), 0.0, \
                dc.velocity_amount
        else:
            drive, brake = pi_ff_step(pf, speed_state, target, ds[MEASURED])
            mode, limit = FORCE, math.inf
        if dc.actuation_delay:  # send what was computed one speed period ago
            if ds[HAS_PENDING]:
                ds[L_MODE], ds[L_DRIVE], ds[L_BRAKE], ds[L_LIMIT] = ds[P_MODE], ds[P_DRIVE], ds[P_BRAKE], ds[P_LIMIT]
            else:
                ds[L_MODE], ds[L_DRIVE], ds[L_BRAKE], ds[L_LIMIT] = POWER, 0.0, 0.0, math.inf
            ds[HAS_PENDING], ds[P_MODE], ds[P_DRIVE], ds[P_BRAKE], ds[P_LIMIT] = 1.0, mode, drive, brake, limit
        else:
            ds[L_MODE], ds[L_DRIVE], ds[L_BRAKE], ds[L_LIMIT] = mode, drive, brake, limit
    return True


@dataclass(slots=True)
class _Task:
    mode: DriverMode = DriverMode.MANUAL
    speed: float = 0.0
    """Ordered speed [m/s]; NaN: the path's."""
    path: Trajectory | None = None
    error: str = ""


_NO_PATH = Trajectory.from_points([(0.0, 0.0)])


class Driver:
    """The self-driver of one car.

    Its logic runs compiled (:func:`driver_step`) on a state array, so a scenario can run it inside a
    compiled loop; this class gives it orders, feeds it readings and reads its command and status.

    Args:
        vehicle: the car's parameters (feed-forward, geometry).
        params: controllers and options.
        step: the simulator's physics step [s]; every period must be a whole multiple of it.
    """

    def __init__(self, vehicle: VehicleParams, params: DriverParams | None = None, step: float = 0.01) -> None:
        self.vehicle, self.step = vehicle, step
        self.params = p = params or DriverParams()
        self.speed_ctrl = make_speed_controller(p, vehicle)
        self.path_ctrl = make_path_controller(p, vehicle)
        clock = Clock(seconds_to_ns(step))
        self.speed_ticks = clock.period_ticks(1.0 / self.speed_ctrl.period, f"{p.speed_controller} period")
        self.path_ticks = clock.period_ticks(1.0 / self.path_ctrl.period, f"{p.path_controller} period")
        self.period_ticks = math.gcd(self.speed_ticks, self.path_ticks)
        self.period = self.period_ticks * clock.step_s
        self.consts = DriverConsts(SPEED_CONTROLLERS.index(p.speed_controller),
                                   PATH_CONTROLLERS.index(p.path_controller), self.speed_ticks, self.path_ticks,
                                   self.period_ticks, self.period, p.actuation_delay, p.stop_deceleration,
                                   p.rest_speed, vehicle.mass, p.vilma_pid.velocity_amount)
        self.controller_consts = (VilmaPid(p.vilma_pid).consts, PiFf(vehicle, p.pi_ff).consts,
                                  VilmaHeading(p.vilma_heading).consts, PurePursuit(vehicle, p.pure_pursuit).consts,
                                  Stanley(vehicle, p.stanley).consts)
        self.estimator = make_estimator(p.pose_source, vehicle)
        self.state = np.zeros(N_STATE)
        """The compiled driver's state (slots :data:`TICKS` ... :data:`CROSS`)."""
        self.state[L_LIMIT] = math.inf
        self.task = _Task()
        self.stamp_ns = 0
        """Stamp of the latest pose [ns]."""

    # -- orders ------------------------------------------------------------------------------------------

    def manual(self) -> None:
        """Stop commanding; the car keeps its last command (as the original's setManualControl)."""
        self._start(_Task(DriverMode.MANUAL))

    def set_speed(self, speed: float) -> None:
        """Hold ``speed`` [m/s] straight ahead."""
        self._start(_Task(DriverMode.SET_SPEED, speed=_finite(speed, "speed")))

    def hold_current_speed(self) -> None:
        """Hold the speed measured now (truncated to an integer with the original's quirks)."""
        v = float(self.state[MEASURED])
        if self.params.speed_controller == "vilma_pid" and self.params.vilma_pid.integer_target:
            v = float(math.trunc(v))
        self._start(_Task(DriverMode.HOLD_SPEED, speed=v))

    def go_to(self, x: float, y: float, speed: float) -> None:
        """Drive to the point ``(x, y)`` [m] at ``speed`` [m/s] and stop on it."""
        x, y, speed = _finite(x, "x"), _finite(y, "y"), _finite(speed, "speed")
        start = (float(self.state[X]), float(self.state[Y])) if self.state[HAS_POSE] else (0.0, 0.0)
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
        ds = self.state
        ds[TICKS], ds[MODE], ds[SPEED] = 0.0, MODES.index(task.mode), task.speed
        ds[STOPPING] = ds[ARRIVED] = ds[HAS_PENDING] = ds[HAS_PROGRESS] = 0.0

    # -- the loop ----------------------------------------------------------------------------------------

    def step_args(self) -> tuple:
        """The arguments of :func:`driver_step` for the present task."""
        path = self.task.path
        return (self.consts, self.state, (path or _NO_PATH).arrays, path is not None, self.controller_consts[0],
                self.controller_consts[1], self.speed_ctrl.state, *self.controller_consts[2:], self.path_ctrl.state)

    def update(self, readings: dict[str, Readings]) -> ActuatorCommand | None:
        """Take one period's readings; returns the command to send now, or None in manual mode."""
        pose = self.estimator.update(readings)
        ds = self.state
        if pose is not None:
            self.stamp_ns = pose.stamp_ns
            ds[HAS_POSE], ds[X], ds[Y], ds[YAW], ds[POSE_SPEED], ds[YAW_RATE] = (1.0, pose.x, pose.y, pose.yaw,
                                                                                  pose.speed, pose.yaw_rate)
            ds[MEASURED] = self._measured_speed(readings, pose)
        if not driver_step(*self.step_args()):
            return None
        return self.command()

    def command(self) -> ActuatorCommand:
        """The command the driver's state holds."""
        ds = self.state.tolist()
        return ActuatorCommand(stamp_ns=self.stamp_ns, steer=ds[STEER], longitudinal=LONGITUDINAL[int(ds[L_MODE])],
                               drive=ds[L_DRIVE], brake=ds[L_BRAKE], velocity_limit=ds[L_LIMIT], autonomous=True)

    def _measured_speed(self, readings: dict[str, Readings], pose: PoseEstimate) -> float:
        vel = readings.get("velocity")
        if self.params.original_speed and vel is not None and len(vel):
            m = vel.latest()
            return math.sqrt(m.vx_world**2 + m.vy_world**2 + m.wz**2)
        return pose.speed

    @property
    def status(self) -> DriverStatus:
        """What the driver is doing, for the ``driver/status`` topic."""
        t, ds = self.task, self.state
        if ds[HAS_PROGRESS]:
            index, progress, remaining, cross = int(ds[INDEX]), ds[PROGRESS], ds[REMAINING], ds[CROSS]
        else:
            index, progress, remaining, cross = 0, 0.0, 0.0, math.nan
        target = target_speed(ds, (t.path or _NO_PATH).arrays) if t.mode != DriverMode.MANUAL else 0.0
        return DriverStatus(self.stamp_ns, t.mode.value, float(target), float(ds[MEASURED]), index,
                            float(progress), float(remaining), float(cross), bool(ds[ARRIVED]), t.error)


def _finite(v: float, name: str) -> float:
    v = float(v)
    if not np.isfinite(v):
        raise ValueError(f"driver order: {name} must be a finite number, got {v!r}")
    return v
