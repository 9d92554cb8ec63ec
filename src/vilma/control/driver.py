"""The self-driver (the paper's ``VilmaSelfDriver``): modes, controller scheduling and the final stop.

Modes as the original GUI offers them: manual (no commands), set speed,
hold the current speed, go to a point, follow a trajectory from its first
point to its end and stop there at rest; and vilma's own: drive a planner's
moving local trajectory (:meth:`Driver.drive_plan`). The speed and path
controllers run at their own periods (each a whole multiple of the physics step,
checked); :meth:`Driver.update` is called every :attr:`Driver.period` with
the sensor readings of that period and returns the command to send.

The final approach is the driver's, not the speed controller's (the
original's PID cannot brake): once the remaining distance is what braking
at ``stop_deceleration`` needs, the driver brakes to stop on the last point
and then holds the brake.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np
from numba import njit

from vilma.control import registry
from vilma.control.path.vilma_heading import VilmaHeadingParams
from vilma.control.registry import Controller, path_step, speed_step
from vilma.control.speed.vilma_pid import VilmaPidParams
from vilma.core.clock import Clock, seconds_to_ns
from vilma.core.messages import ActuatorCommand, DriverStatus, PoseEstimate
from vilma.localization import SOURCES, make_estimator
from vilma.sensors import Readings
from vilma.trajectory import Trajectory, speed_profile
from vilma.trajectory.trajectory import path_project, path_speed_at
from vilma.vehicle.actuators import FORCE, MODE_IDS, POWER
from vilma.vehicle.params import VehicleParams


class DriverMode(StrEnum):
    """What the self-driver is doing."""

    MANUAL = "manual"
    SET_SPEED = "set_speed"
    HOLD_SPEED = "hold_speed"
    GO_TO_POINT = "go_to_point"
    FOLLOW = "follow"
    PLAN = "plan"


@dataclass(frozen=True, slots=True, kw_only=True)
class DriverParams:
    """Which controllers the driver uses, their parameters, and how it measures and stops."""

    speed_controller: str = "pi_ff"
    """A registered speed controller (:func:`vilma.control.registry.names`)."""
    path_controller: str = "stanley"
    """A registered path controller."""
    pose_source: str = "truth"
    """``truth`` (the simulator's exact pose) or ``ekf`` (fused GPS, IMU and wheel speeds)."""
    gains: tuple[tuple[str, Any], ...] = ()
    """Parameters of controllers by name (a mapping is taken too); a controller not named here has its defaults
    (:meth:`gains_of`). Kept sorted by name, without the controllers at their defaults."""
    original_speed: bool = False
    """Measure speed as the original: sqrt(vx^2 + vy^2 + wz^2), world-frame velocity plus the yaw rate (a bug)."""
    actuation_delay: bool = False
    """Send each speed command one speed period after computing it, as the original's sleep-then-send."""
    stop_deceleration: float = 2.0
    """Braking of the final approach and ahead of curves [m/s^2]."""
    max_lateral_accel: float = 2.0
    """Lateral acceleration the speed profile allows in curves [m/s^2]."""
    max_accel: float = 1.5
    """Acceleration a profile timed to arrive in a goal's window plans with [m/s^2]
    (:func:`~vilma.trajectory.arrival_profile`)."""
    rest_speed: float = 0.05
    """Below this speed [m/s] the car is at rest."""

    def __post_init__(self) -> None:
        for name, kind in (("speed_controller", registry.SPEED), ("path_controller", registry.PATH)):
            try:
                registry.controller_type(getattr(self, name), kind)
            except ValueError as e:
                raise ValueError(f"driver {name}: {e}") from None
        if self.pose_source not in SOURCES:
            raise ValueError(f"driver pose_source {self.pose_source!r} is unknown; use one of {', '.join(SOURCES)}")
        gains = dict(self.gains)
        for name, params in gains.items():
            try:
                expected = registry.controller_type(name).params
            except ValueError as e:
                raise ValueError(f"driver gains: {e}") from None
            if not isinstance(params, expected):
                raise ValueError(f"driver gains of {name}: expected {expected.__name__}, got {type(params).__name__}")
        # one spelling (sorted, defaults left out), so that parameters that drive alike compare equal
        object.__setattr__(self, "gains", tuple(sorted((name, params) for name, params in gains.items()
                                                       if params != type(params)())))
        for name in ("stop_deceleration", "max_lateral_accel", "max_accel"):
            if not 0 < getattr(self, name) < math.inf:
                raise ValueError(f"driver {name} must be a finite number > 0 m/s^2, got {getattr(self, name)!r}")
        if not 0 <= self.rest_speed < math.inf:
            raise ValueError(f"driver rest_speed must be a finite number >= 0 m/s, got {self.rest_speed!r}")

    def gains_of(self, name: str) -> Any:
        """The parameters of the controller ``name``: as set, or its defaults."""
        params = dict(self.gains).get(name)
        return registry.controller_type(name).params() if params is None else params

    def with_gains(self, gains: Mapping[str, Any]) -> DriverParams:
        """These parameters with the controllers' parameters in ``gains`` (by name) replaced."""
        return dataclasses.replace(self, gains={**dict(self.gains), **gains})

    @classmethod
    def original(cls) -> DriverParams:
        """The shipped program: its PID with its quirks, Turn-Wheels with its quirks, its speed formula and delay."""
        return cls(speed_controller="vilma_pid", path_controller="vilma_heading",
                   gains={"vilma_pid": VilmaPidParams.original(),
                          "vilma_heading": VilmaHeadingParams(original_quirks=True)},
                   original_speed=True, actuation_delay=True)


def make_controller(params: DriverParams, kind: str, vehicle: VehicleParams) -> Controller:
    """The configured controller of ``kind`` (speed or path) for ``vehicle``."""
    name = params.speed_controller if kind == registry.SPEED else params.path_controller
    return registry.controller_type(name).make(vehicle, params.gains_of(name))


MODES = tuple(DriverMode)
"""Mode ids of the compiled driver: the index in this tuple."""
MANUAL, FOLLOW, PLAN = (MODES.index(m) for m in (DriverMode.MANUAL, DriverMode.FOLLOW, DriverMode.PLAN))
LONGITUDINAL = {v: k for k, v in MODE_IDS.items()}
"""Compiled longitudinal mode id -> :class:`Longitudinal`."""

DRIVER_STATE = np.dtype([
    ("ticks", np.int64), ("mode", np.int64), ("speed", np.float64), ("stopping", np.bool_), ("arrived", np.bool_),
    ("has_pose", np.bool_), ("x", np.float64), ("y", np.float64), ("yaw", np.float64), ("pose_speed", np.float64),
    ("yaw_rate", np.float64), ("measured", np.float64), ("steer", np.float64),
    ("command_mode", np.int64), ("drive", np.float64), ("brake", np.float64), ("velocity_limit", np.float64),
    ("has_pending", np.bool_), ("pending_mode", np.int64), ("pending_drive", np.float64),
    ("pending_brake", np.float64), ("pending_limit", np.float64),
    ("has_progress", np.bool_), ("index", np.int64), ("progress", np.float64), ("remaining", np.float64),
    ("cross", np.float64)])
"""The driver's state record: ticks since the order, mode id, ordered speed [m/s] (NaN: the path's), final stop
under way, arrived, pose known and the pose (x, y [m], yaw [rad], speed [m/s], yaw rate [rad/s]), measured speed
[m/s], steering [rad], the longitudinal command (mode id, drive, brake, velocity limit), the one held back by the
actuation delay, and the progress on the path (segment, s, left [m], cross-track [m])."""


def driver_state() -> np.ndarray:
    """A fresh driver state, one row (1,) of :data:`DRIVER_STATE`: its element is a record compiled code reads and
    writes by field name."""
    row = np.zeros(1, DRIVER_STATE)
    row["velocity_limit"] = math.inf
    return row


PROGRESS_WINDOW = 40
"""Segments searched on each side of the last projection when tracking progress."""


class DriverConsts(NamedTuple):
    """The driver's parameters as compiled code reads them."""

    speed_ticks: int
    path_ticks: int
    period_ticks: int
    period: float
    actuation_delay: bool
    stop_deceleration: float
    rest_speed: float
    mass: float


@njit(cache=True)
def target_speed(ds, pa):
    """The speed the driver aims at now [m/s]: ordered, or the path's at the progress made."""
    if (ds.mode == FOLLOW or ds.mode == PLAN) and math.isnan(ds.speed):
        return path_speed_at(pa, ds.progress if ds.has_progress else 0.0)
    return ds.speed


@njit(cache=True)
def aimed_speed(dc, ds, pa):
    """The speed the driver aims at now [m/s], as its status and the drive log tell it: :func:`target_speed`,
    but on the final stop at most the speed from which the stop deceleration brings the car to rest on the last
    point, sqrt(2 a d) (the curve the stop begins on, :func:`_track`), and 0 once arrived; 0 in manual mode.
    (The speed controller is not stepped on the stop: the brakes are, :func:`_final_stop`.)"""
    if ds.mode == MANUAL or ds.arrived:
        return 0.0
    v = target_speed(ds, pa)
    if ds.stopping:
        return min(v, math.sqrt(2.0 * dc.stop_deceleration * max(ds.remaining, 0.0)))
    return v


@njit(cache=True)
def _stops(ds, pa, rest_speed):
    """Whether the path ends in a stop: always, but for a planner's local trajectory, which may end moving (the
    next plan goes on from it)."""
    return ds.mode != PLAN or path_speed_at(pa, pa.s[pa.s.shape[0] - 1]) < rest_speed


@njit(cache=True)
def _track(dc, ds, pa):
    """Progress along the path and the switch to the final stop."""
    hint = ds.index if ds.has_progress else -1
    # an int64, as the controllers' windows are (a constant would compile path_project once more, for a literal)
    i, _, s, cross, _, _, _, left = path_project(pa, ds.x, ds.y, hint, np.int64(PROGRESS_WINDOW))
    ds.has_progress, ds.index, ds.progress, ds.remaining, ds.cross = True, i, s, left, cross
    v = ds.measured
    braking = v * v / (2.0 * dc.stop_deceleration)
    if not ds.stopping and left <= braking + v * dc.period and _stops(ds, pa, dc.rest_speed):
        ds.stopping = True


@njit(cache=True)
def _final_stop(dc, ds):
    """Brake to stop on the last point: deceleration v^2 / (2 d) (at most twice the stop deceleration but on a
    planner's stop), then hold."""
    v, d = ds.measured, max(ds.remaining, 0.05)
    if ds.arrived or abs(v) < dc.rest_speed:
        ds.arrived = True
        decel = dc.stop_deceleration
    elif ds.mode == PLAN:  # the planner's stop, checked against the car's brakes: as hard as it needs
        decel = v * v / (2.0 * d)
    else:
        decel = min(v * v / (2.0 * d), 2.0 * dc.stop_deceleration)
    ds.command_mode, ds.drive, ds.brake, ds.velocity_limit = FORCE, 0.0, dc.mass * decel, math.inf


@njit(cache=True)
def driver_step(dc, ds, pa, has_path, sc, ss, pc, ps):
    """One driver period on the pose and measured speed already in ``ds``; True if it commands.

    ``sc``, ``ss`` are the speed controller's constants and state, ``pc``, ``ps`` the path controller's
    (dispatched by :mod:`~vilma.control.registry`). The command is left in ``ds`` (steer, command_mode ...).
    """
    ticks = ds.ticks
    run_speed = ticks % dc.speed_ticks == 0
    run_path = ticks % dc.path_ticks == 0
    ds.ticks = ticks + dc.period_ticks
    if ds.mode == MANUAL or not ds.has_pose:
        return False
    if has_path:
        if run_path:
            steer, passed_end = path_step(pc, ps, pa, ds.x, ds.y, ds.yaw, ds.pose_speed, ds.yaw_rate)
            ds.steer = steer
            if passed_end and _stops(ds, pa, dc.rest_speed):  # no more path (Turn-Wheels passed the last point)
                ds.stopping = True
        _track(dc, ds, pa)
    else:
        ds.steer = 0.0
    if ds.stopping or ds.arrived:
        _final_stop(dc, ds)
    elif run_speed:
        mode, drive, brake, limit = speed_step(sc, ss, target_speed(ds, pa), ds.measured, ds.steer)
        if dc.actuation_delay:  # send what was computed one speed period ago
            if ds.has_pending:
                ds.command_mode, ds.drive, ds.brake, ds.velocity_limit = (ds.pending_mode, ds.pending_drive,
                                                                          ds.pending_brake, ds.pending_limit)
            else:
                ds.command_mode, ds.drive, ds.brake, ds.velocity_limit = POWER, 0.0, 0.0, math.inf
            ds.has_pending = True
            ds.pending_mode, ds.pending_drive, ds.pending_brake, ds.pending_limit = mode, drive, brake, limit
        else:
            ds.command_mode, ds.drive, ds.brake, ds.velocity_limit = mode, drive, brake, limit
    return True


@dataclass(slots=True)
class _Task:
    mode: DriverMode = DriverMode.MANUAL
    speed: float = 0.0
    """Ordered speed [m/s]; NaN: the path's."""
    path: Trajectory | None = None
    error: str = ""


_NO_PATH = Trajectory.from_points([(0.0, 0.0)])
_profiled = lru_cache(maxsize=8)(speed_profile)
""":func:`speed_profile` made once for a path followed again (a sweep, a benchmark: a scenario's path is made once),
and with it the arrays compiled code reads; a path is immutable, its identity the key."""


class Driver:
    """The self-driver of one car.

    Its logic runs compiled (:func:`driver_step`) on a state record, so a scenario can run it inside a
    compiled loop; this class gives it orders, feeds it readings and reads its command and status.

    Args:
        vehicle: the car's parameters (feed-forward, geometry).
        params: controllers and options.
        step: the simulator's physics step [s]; every period must be a whole multiple of it.
    """

    def __init__(self, vehicle: VehicleParams, params: DriverParams | None = None, step: float = 0.01) -> None:
        self.vehicle, self.step = vehicle, step
        self.params = p = params or DriverParams()
        self.speed_ctrl = make_controller(p, registry.SPEED, vehicle)
        self.path_ctrl = make_controller(p, registry.PATH, vehicle)
        clock = Clock(seconds_to_ns(step))
        self.speed_ticks = clock.period_ticks(1.0 / self.speed_ctrl.period, f"{p.speed_controller} period")
        self.path_ticks = clock.period_ticks(1.0 / self.path_ctrl.period, f"{p.path_controller} period")
        self.period_ticks = math.gcd(self.speed_ticks, self.path_ticks)
        self.period = self.period_ticks * clock.step_s
        self.consts = DriverConsts(self.speed_ticks, self.path_ticks, self.period_ticks, self.period,
                                   p.actuation_delay, p.stop_deceleration, p.rest_speed, vehicle.mass)
        self.estimator = make_estimator(p.pose_source, vehicle)
        row = driver_state()
        self.state = row.view(np.recarray)[0]
        """The compiled driver's state (:data:`DRIVER_STATE`), its fields as attributes."""
        self._ds = row[0]
        """The same state as a plain structured scalar, for the per-period path: its fields by item (``ds["x"]``)
        are read and written several times faster than the record's attributes, and compiled calls take it faster."""
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
        v = float(self.state.measured)
        if getattr(self.speed_ctrl.params, "integer_target", False):  # a controller that truncates its target
            v = float(math.trunc(v))
        self._start(_Task(DriverMode.HOLD_SPEED, speed=v))

    def go_to(self, x: float, y: float, speed: float) -> None:
        """Drive to the point ``(x, y)`` [m] at ``speed`` [m/s] and stop on it."""
        x, y, speed = _finite(x, "x"), _finite(y, "y"), _finite(speed, "speed")
        start = (float(self.state.x), float(self.state.y)) if self.state.has_pose else (0.0, 0.0)
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
        profiled = _profiled(path, speed, self.params.max_lateral_accel, self.params.stop_deceleration)
        self._start(_Task(DriverMode.FOLLOW, speed=math.nan, path=profiled))

    def drive_plan(self, path: Trajectory) -> None:
        """Drive a planner's local trajectory ``path`` (with speeds), replacing the one driven, if any, on the go.

        The controllers and the driver's clock run on (a replan is not a new order); the car stops at the end only
        when the path's own speeds end at rest (a planner's stop), braking as hard as that stop needs; a stop under
        way or made holds while the plans that follow end at rest too (each one's end, moved by the noise of what
        it stops behind, would otherwise start the car creeping again). Points that repeat where the plan stands
        still are dropped; a plan of one point (the car at rest) is a stop on it.
        """
        if path.speed is None:
            raise ValueError("drive plan: the trajectory has no speeds")
        ds = self._ds
        moving = _moving(path, ds["yaw"])
        if self.task.mode != DriverMode.PLAN:
            self._start(_Task(DriverMode.PLAN, speed=math.nan, path=moving))
        else:
            self.task.path = moving
            ds["has_progress"] = False  # the progress is on the new path
            if moving.speed[-1] >= self.params.rest_speed:  # it drives on: a stop under way is called off
                ds["stopping"] = ds["arrived"] = False
        ds["stopping"] |= not moving.speed.any()  # a plan at rest all along: a stop where the car stands

    def _start(self, task: _Task) -> None:
        self.task = task
        self.speed_ctrl.reset()
        self.path_ctrl.reset()
        ds = self.state
        ds.ticks, ds.mode, ds.speed = 0, MODES.index(task.mode), task.speed
        ds.stopping = ds.arrived = ds.has_pending = ds.has_progress = False

    # -- the loop ----------------------------------------------------------------------------------------

    def step_args(self) -> tuple:
        """The arguments of :func:`driver_step` for the present task."""
        path = self.task.path
        return (self.consts, self._ds, (path or _NO_PATH).arrays, path is not None, self.speed_ctrl.consts,
                self.speed_ctrl.state, self.path_ctrl.consts, self.path_ctrl.state)

    def update(self, readings: dict[str, Readings]) -> ActuatorCommand | None:
        """Take one period's readings; returns the command to send now, or None in manual mode."""
        pose = self.estimator.update(readings)
        ds = self._ds
        if pose is not None:
            self.stamp_ns = pose.stamp_ns
            ds["has_pose"], ds["x"], ds["y"], ds["yaw"] = True, pose.x, pose.y, pose.yaw
            ds["pose_speed"], ds["yaw_rate"] = pose.speed, pose.yaw_rate
            ds["measured"] = self._measured_speed(readings, pose)
        if not driver_step(*self.step_args()):
            return None
        return self.command()

    def command(self) -> ActuatorCommand:
        """The command the driver's state holds."""
        ds = self._ds
        return ActuatorCommand(stamp_ns=self.stamp_ns, steer=float(ds["steer"]),
                               longitudinal=LONGITUDINAL[int(ds["command_mode"])], drive=float(ds["drive"]),
                               brake=float(ds["brake"]), velocity_limit=float(ds["velocity_limit"]), autonomous=True)

    def _measured_speed(self, readings: dict[str, Readings], pose: PoseEstimate) -> float:
        vel = readings.get("velocity")
        if self.params.original_speed and vel is not None and len(vel):
            m = vel.latest()
            return math.sqrt(m.vx_world**2 + m.vy_world**2 + m.wz**2)
        return pose.speed

    @property
    def status(self) -> DriverStatus:
        """What the driver is doing, for the ``driver/status`` topic."""
        t, ds = self.task, self._ds
        if ds["has_progress"]:
            index, progress, remaining, cross = int(ds["index"]), ds["progress"], ds["remaining"], ds["cross"]
        else:
            index, progress, remaining, cross = 0, 0.0, 0.0, math.nan
        target = aimed_speed(self.consts, ds, (t.path or _NO_PATH).arrays)
        return DriverStatus(self.stamp_ns, t.mode.value, float(target), float(ds["measured"]), index,
                            float(progress), float(remaining), float(cross), bool(ds["arrived"]), t.error)


def _moving(path: Trajectory, yaw: float) -> Trajectory:
    """``path`` without the points that repeat (1 mm apart or less; the last of each run kept, with its speed); a
    path of one point gets a second 1 m ahead along ``yaw`` [rad], both at rest."""
    xy, speed = path.xy, path.speed
    keep = np.append(np.hypot(*np.diff(xy, axis=0).T) > 1e-3, True)
    xy, speed = xy[keep], speed[keep]
    if len(xy) == 1:
        xy = np.vstack([xy, xy[0] + (math.cos(yaw), math.sin(yaw))])
        speed = np.zeros(2)
    return Trajectory(xy, speed)


def _finite(v: float, name: str) -> float:
    v = float(v)
    if not np.isfinite(v):
        raise ValueError(f"driver order: {name} must be a finite number, got {v!r}")
    return v
