"""The simulator and the self-driver as bus nodes: what ``vilma sim``, ``vilma drive`` and ``vilma up`` run.

:class:`SimNode` advances the simulator one frame at a time (paced by the
caller), publishes every reading on its sensor topic and a ``sim/status``
after each frame (the frame's end: the driver's clock), and applies the
commands that arrive on ``cmd`` at the start of the next frame. It answers
``sim/cmd`` (reset, status).

:class:`DriverNode` collects the readings of each frame, runs the driver
once per driver period of sim time when a frame ends, publishes the command
on ``cmd`` and its status on ``driver/status``, and takes orders on
``driver/cmd``; each order it took is published there too, for recorders. Every order's speed, goal and points are
checked alike (:mod:`vilma.bus.orders`). A ``follow`` order may name a
trajectory file only in the data folder the driver was given (none: file orders are refused), and the reply
never quotes a file: a peer is not a user of this machine. A ``plan`` order plans on the scans of ``objects`` or
``laser`` each replan period of sim time (:mod:`vilma.bus.plan_node`).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec
import numpy as np

from vilma.bus.base import Bus
from vilma.bus.orders import check_goal, check_points, order_speed
from vilma.bus.topics import SENSOR_TOPICS, topic
from vilma.control import registry
from vilma.control.driver import Driver, DriverMode, DriverParams
from vilma.core.closing import Closeable
from vilma.core.messages import MAX_ORDER_POINTS, ActuatorCommand, DriverOrder, Message, Reply, SimControl, SimStatus
from vilma.core.ratelimit import WarningThrottle
from vilma.sensors import Readings
from vilma.sim import Simulator
from vilma.trajectory import Trajectory, TrajectoryFileError, check_trajectory_file, load_trajectory
from vilma.vehicle.actuators import CommandError
from vilma.vehicle.state import VehicleState

if TYPE_CHECKING:  # the planner (numba, scipy.interpolate) is imported for a plan order only
    from vilma.bus.plan_node import LivePlan, PlanSetup

log = logging.getLogger(__name__)


class SimNode(Closeable):
    """The simulator on a bus (see the module docstring). ``on_frame`` also gets each frame's readings."""

    def __init__(self, sim: Simulator, bus: Bus, car: str = "vilma", start: VehicleState | None = None,
                 on_frame: Callable[[dict[str, Readings]], None] | None = None) -> None:
        self.sim, self.bus, self.car = sim, bus, car
        self.start = start or sim.config.initial
        self.on_frame = on_frame
        self.on_captures: Callable[[list[tuple[str, Message]]], None] | None = None
        """Also gets each frame's world-sensor captures (topic name, message), when there are any."""
        self._pending: list[ActuatorCommand] = []
        self._lock = threading.Lock()
        self._reset = False
        self._reset_done: list[Callable[[], None]] = []
        self.real_time_factor = math.nan
        self.frame_ns = 0
        """Sim time the last frame advanced [ns]."""
        self.on_time = self.late = 0
        """Commands that arrived within one frame of the sim time they were computed at (stamped), or later."""
        self._keys = {name: topic(name, car) for name in SENSOR_TOPICS}
        self._subs = [bus.subscribe(topic("cmd", car), self.command), bus.serve(topic("sim/cmd", car), self._order)]
        self._warnings = WarningThrottle(log)  # a peer flooding bad commands gets a line a second

    def command(self, cmd: Message) -> None:
        """Take a command from any thread; it applies at the start of the next frame."""
        with self._lock:
            self._pending.append(cmd)

    def reset(self, on_done: Callable[[], None] | None = None) -> None:
        """Put the car back at its start pose at the start of the next frame (any thread); ``on_done`` is then
        called on the simulator's thread, before that frame's readings go out."""
        with self._lock:
            self._reset = True
            if on_done is not None:
                self._reset_done.append(on_done)

    def _order(self, order: SimControl) -> Reply:
        if order.action == "reset":
            self.reset()
            return Reply(ok=True)
        if order.action == "status":
            return Reply(ok=True, error=f"t={self.sim.clock.time_s:.3f} s")
        return Reply(ok=False, error=f"unknown simulator order {order.action!r}; use reset or status")

    def frame(self, readings: dict[str, Readings], frame_ns: int = 0) -> None:
        """After the simulator advanced one frame (of ``frame_ns``): publish what it measured (the world
        sensors' captures too), then its status."""
        self.frame_ns = frame_ns
        publish_readings(self.bus, self._keys, readings)
        captures = self.sim.take_captures()
        for name, msg in captures:
            self.bus.publish(topic(name, self.car), msg)
        if self.on_frame is not None:
            self.on_frame(readings)
        if captures and self.on_captures is not None:
            self.on_captures(captures)
        self.bus.publish(topic("sim/status", self.car), self.sim.status(self.real_time_factor))
        self.apply_pending()

    def apply_pending(self) -> None:
        """Apply the commands and the reset that arrived since the last frame."""
        with self._lock:
            pending, self._pending = self._pending, []
            reset, self._reset = self._reset, False
            done, self._reset_done = self._reset_done, []
        if reset:
            self.sim.reset(self.start)
            for on_done in done:
                on_done()
        for cmd in pending:
            if cmd.stamp_ns:
                if self.sim.time_ns - cmd.stamp_ns <= self.frame_ns:
                    self.on_time += 1
                else:
                    self.late += 1
            try:
                self.sim.command(cmd)
            except CommandError as e:
                self._warnings.warning("refused", "refused a command: %s", e)

    def close(self) -> None:
        """Leave the bus (closing again does nothing)."""
        for s in self._subs:
            s.close()


def publish_readings(bus: Bus, keys: dict[str, str], readings: dict[str, Readings]) -> None:
    """Every reading, oldest first, on its sensor's topic ``keys[name]`` (sensors without a key are skipped)."""
    for name, r in readings.items():
        key = keys.get(name)
        if key is not None:
            for msg in r.messages():
                bus.publish(key, msg)


def readings_of(name: str, messages: list[Message]) -> Readings:
    """Messages of one sensor back into :class:`Readings` (in stamp order)."""
    messages = sorted(messages, key=lambda m: m.stamp_ns)
    rows = [msgspec.structs.astuple(m) for m in messages]
    return Readings(name, SENSOR_TOPICS[name], np.array([r[0] for r in rows], dtype=np.int64),
                    np.array([r[1:] for r in rows], dtype=float))


MAX_CATCH_UP = 100
"""Driver periods one simulator frame may ask for at most; a frame further ahead (a foreign status, a jump of
the clock) starts the driver's clock again from it instead of running every period in between."""


class DriverNode(Closeable):
    """The self-driver on a bus (see the module docstring)."""

    def __init__(self, driver: Driver, bus: Bus, car: str = "vilma", step_ns: int = 10_000_000,
                 data_dir: Path | None = None, planning: PlanSetup | None = None) -> None:
        self.driver, self.bus, self.car = driver, bus, car
        self.data_dir = data_dir.resolve() if data_dir is not None else None
        """The folder whose trajectory files ``follow`` orders may name (None: no file orders)."""
        self.planning = planning
        """How ``plan`` orders plan (None: the defaults of :class:`~vilma.bus.plan_node.PlanSetup`)."""
        self._plan: LivePlan | None = None
        self._plan_next: LivePlan | None = None  # a plan order taken, which starts at the next frame's end
        self._scans: list[Message] = []  # the object lists and laser scans of a frame, while planning
        self.period_ns = driver.period_ticks * step_ns
        self._inbox: dict[str, list[Message]] = {name: [] for name in SENSOR_TOPICS}
        self._lock = threading.Lock()
        self._next_ns: int | None = None
        self._warnings = WarningThrottle(log)
        self.commands_sent = 0
        self.on_pose: Callable[[], None] | None = None
        """Called once, at the end of the first period in which the driver knows the car's pose."""
        self._subs = [bus.subscribe(topic(name, car), self._collector(name)) for name in SENSOR_TOPICS]
        self._subs += [bus.subscribe(topic(name, car), self._scan) for name in ("objects", "laser")]
        self._subs += [bus.subscribe(topic("sim/status", car), self._frame_end),
                       bus.serve(topic("driver/cmd", car), self.order)]

    def _collector(self, name: str):
        box = self._inbox[name]

        def take(msg: Message) -> None:
            with self._lock:
                box.append(msg)
        return take

    def _scan(self, msg: Message) -> None:
        with self._lock:
            if self._plan is not None or self._plan_next is not None:
                self._scans.append(msg)

    def _frame_end(self, status: SimStatus) -> None:
        t = status.stamp_ns
        if self._next_ns is None or t < self._next_ns - self.period_ns:  # the first frame, or the sim was reset
            self._next_ns = t
        if t < self._next_ns:
            return
        with self._lock:
            readings = {name: readings_of(name, box) for name, box in self._inbox.items() if box}
            for box in self._inbox.values():
                box.clear()
        periods = 1 + (t - self._next_ns) // self.period_ns
        if periods > MAX_CATCH_UP:
            self._warnings.warning("jump", "driver: a simulator frame %.3g s ahead of the last; the driver takes "
                                   "up from it", (t - self._next_ns) * 1e-9)
            periods, self._next_ns = 1, t
        ends = [self._next_ns + i * self.period_ns for i in range(periods)]
        self._next_ns += periods * self.period_ns
        cmd = None
        for i in range(periods):  # one update per driver period of sim time; the readings go to the first
            cmd = self.driver.update(readings if i == 0 else {}) or cmd
        self._plan_periods(ends)
        if self.on_pose is not None and self.driver.estimator.estimate is not None:
            hook, self.on_pose = self.on_pose, None
            hook()
        if cmd is not None:
            self.bus.publish(topic("cmd", self.car), cmd)
            self.commands_sent += 1
        self.bus.publish(topic("driver/status", self.car), self.driver.status)

    def _plan_periods(self, ends: list[int]) -> None:
        """After the driver's periods ending at ``ends`` [ns]: the plan under way takes the frame's scans, then
        plans as its replan periods are over (a plan just ordered plans at once)."""
        with self._lock:
            scans, self._scans = self._scans, []
            started = self._plan_next is not None
            if started:
                self._plan, self._plan_next = self._plan_next, None
            plan = self._plan
        if plan is None:
            return
        plan.perceive(scans, self.driver.estimator.estimate)
        if started:
            plan.cycle(ends[-1])
        else:
            for t in ends:
                plan.period_done(t)

    def order(self, order: DriverOrder) -> Reply:
        """Carry out an order; a Reply says whether it was taken, or why not. An order taken is published on
        ``driver/cmd``, stamped with the driver's time (a go-to and a follow with the points of the path driven:
        its start, a file's points, a plan with its route), so that a recording holds the driver's task. Any order
        but a tune ends the plan under way."""
        d, a, plan = self.driver, order.action, None
        stamp = d.stamp_ns  # now: a tune order swaps the driver for a new one, which has no time yet
        speed = None if math.isnan(order.speed) else order.speed
        top, car = d.vehicle.top_speed, _car(d)
        try:
            if a == "manual":
                d.manual()
            elif a == "set_speed":
                d.set_speed(order_speed(_need(speed, "speed"), top, stop=True))
            elif a == "hold_speed":
                d.hold_current_speed()
            elif a == "go_to":
                check_goal(order.x, order.y, car)
                d.go_to(order.x, order.y, order_speed(_need(speed, "speed"), top))
            elif a == "follow":
                d.follow(_path_of(order, self.data_dir, car, top), None if speed is None else order_speed(speed, top))
            elif a == "plan":
                from vilma.bus.plan_node import PlanSetup, start_plan  # the planner (numba): for a plan only

                plan = start_plan(order, d, self.planning or PlanSetup(), self.bus, self.car)
            elif a == "tune":
                self.set_params(_tuned(d.params, order))
            else:
                return Reply(ok=False, error=f"unknown order {a!r}; use manual, set_speed, hold_speed, go_to, follow,"
                                             " plan, tune")
        except (ValueError, TrajectoryFileError) as e:
            return Reply(ok=False, error=f"{a}: {e}")
        if a != "tune":
            with self._lock:
                self._plan, self._plan_next, self._scans = None, plan, []
        if a in ("go_to", "follow"):
            order = msgspec.structs.replace(order, points=d.task.path.xy.tolist(), file="")
        elif plan is not None:
            route = plan.local.path
            order = msgspec.structs.replace(order, points=route.xy.tolist(), speeds=route.speed.tolist())
        self.bus.publish(topic("driver/cmd", self.car), msgspec.structs.replace(order, stamp_ns=stamp))
        return Reply(ok=True)

    def set_params(self, params: DriverParams) -> None:
        """Swap the driver for one with ``params``; a task under way goes on with the new controllers, and the
        pose estimate is kept when its source is the same.

        Raises:
            ValueError: the parameters do not fit (controller periods, values).
        """
        old = self.driver
        new = Driver(old.vehicle, params, step=old.step)
        task = old.task
        if task.mode in (DriverMode.FOLLOW, DriverMode.GO_TO_POINT) and task.path is not None:
            new.follow(task.path, None if task.path.speed is not None else task.speed)
        elif task.mode in (DriverMode.SET_SPEED, DriverMode.HOLD_SPEED):
            new.set_speed(task.speed)
        elif task.mode == DriverMode.PLAN and task.path is not None:
            new.drive_plan(task.path)
        if params.pose_source == old.params.pose_source:
            new.estimator = old.estimator
        with self._lock:
            for plan in (self._plan, self._plan_next):
                if plan is not None:
                    plan.local.driver = new
        self.driver = new

    def close(self) -> None:
        """Leave the bus (closing again does nothing)."""
        for s in self._subs:
            s.close()


def _car(driver: Driver) -> tuple[float, float]:
    """Where the car is [m], as ``driver`` knows (the origin before it knows)."""
    state = driver.state
    return (float(state.x), float(state.y)) if state.has_pose else (0.0, 0.0)


def _need(value: float | None, name: str) -> float:
    if value is None:
        raise ValueError(f"give {name}")
    return value


def _path_of(order: DriverOrder, data_dir: Path | None, car: tuple[float, float], top: float) -> Trajectory:
    """The path of a ``follow`` order (its points, or its file), checked as every order's (:func:`check_points`)."""
    if order.file:
        path = _data_file(data_dir, order.file)
    elif len(order.points) > MAX_ORDER_POINTS:  # (a decoder refuses them first; this is for in-process senders)
        raise ValueError(f"{len(order.points)} points, over the {MAX_ORDER_POINTS} an order may carry; resample "
                         "the path coarser (vilma trajectory resample)")
    elif len(order.points) < 2:
        raise ValueError("give a trajectory file or at least 2 points")
    else:
        path = Trajectory.from_points(order.points, order.speeds or None)
    check_points(path.xy, path.speed, car, top, "path")
    return path


def _data_file(folder: Path | None, name: str) -> Trajectory:
    """The trajectory in the regular file ``name`` of the data ``folder`` (resolved), links followed.

    Raises:
        ValueError: no folder, a name out of it, or a file that is not a trajectory; the message never quotes
            the file (why it does not parse goes to the log).
    """
    if folder is None:
        raise ValueError("file orders are off: start the driver with --data-dir DIR to follow files in DIR, or send "
                         "the points")
    relative = Path(name)  # (realpath, not resolve: a link loop is left to the check below, which names it)
    if "\0" in name or relative.is_absolute() or ".." in relative.parts or \
            not (path := Path(os.path.realpath(folder / relative))).is_relative_to(folder):
        raise ValueError(f"file {name!r} is not in the driver's data folder; name a file in it (no leading '/', "
                         "no '..', no link out of it)")
    try:
        check_trajectory_file(path)
    except TrajectoryFileError as e:
        raise ValueError(f"file {name!r}: {e.what}") from None
    try:
        return load_trajectory(path)
    except TrajectoryFileError as e:
        log.warning("follow order: %s", e)
        raise ValueError(f"file {name!r}{f' line {e.line}' if e.line else ''}: not a trajectory file (the driver's "
                         "log says why)") from None


def _tuned(base: DriverParams, order: DriverOrder) -> DriverParams:
    """``base`` with the controllers and gains of a ``tune`` order."""
    speed = order.speed_controller or base.speed_controller
    path = order.path_controller or base.path_controller
    speeds, paths = registry.names(registry.SPEED), registry.names(registry.PATH)
    if speed not in speeds or path not in paths:
        raise ValueError(f"controllers {speed!r} + {path!r}: use a speed controller of {', '.join(speeds)}"
                         f" and a path controller of {', '.join(paths)}")
    changes = {}
    for name, fields in order.gains.items():
        if name not in (*speeds, *paths):
            raise ValueError(f"gains of {name!r}: no such controller")
        now = base.gains_of(name)
        known = [f.name for f in dataclasses.fields(now)]
        values = {}
        for field, value in fields.items():
            if field not in known:
                raise ValueError(f"gains of {name}: no field {field!r}; fields are {', '.join(known)}")
            values[field] = _like(getattr(now, field), value, f"gains of {name}: {field}")
        changes[name] = dataclasses.replace(now, **values)
    return dataclasses.replace(base, speed_controller=speed, path_controller=path).with_gains(changes)


def _like(old: object, value: object, what: str) -> object:
    """``value`` as the type of ``old`` (an int is a float too); a finite number where a number belongs."""
    if isinstance(old, bool) or not isinstance(old, int | float):
        if type(value) is not type(old):
            raise ValueError(f"{what} must be a {type(old).__name__}, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value) or \
            (isinstance(old, int) and value != int(value)):
        raise ValueError(f"{what} must be a finite {'integer' if isinstance(old, int) else 'number'}, got {value!r}")
    return type(old)(value)
