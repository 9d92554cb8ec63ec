"""Run a scenario headless: the simulator and the self-driver in lockstep, then the scorecard and the files.

The driver runs at its own period (the gcd of its controllers' periods); each
period the simulator advances that many physics steps, the driver takes the
readings and its command applies from the next step. Lockstep runs as fast as
the machine allows; ``realtime`` paces it with :class:`~vilma.sim.Pacer`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from numba.core.event import TimingListener, install_listener

from vilma.control.driver import Driver
from vilma.scenario.drive_log import DriveLog
from vilma.scenario.fields import SpecError
from vilma.scenario.lockstep import CompiledDrive, compiled_ok, run_compiled
from vilma.scenario.metrics import WATCHDOG_STOP, expectation_failures, plain, scorecard, timing
from vilma.scenario.result import RunObserver, RunResult
from vilma.scenario.spec import Scenario
from vilma.sensors import Readings
from vilma.sim import Pacer, SimConfig, Simulator
from vilma.sim.config import MUJOCO
from vilma.trajectory import Trajectory
from vilma.vehicle.state import VX, YAW, VehicleState, X, Y


def initial_state(scenario: Scenario, path: Trajectory | None) -> VehicleState:
    """The start: the ``initial`` block, else the path's first point facing along it, else the origin."""
    i = scenario.initial
    x0, y0, yaw0 = 0.0, 0.0, 0.0
    if path is not None:
        x0, y0 = (float(v) for v in path.xy[0])
        yaw0 = path.heading_at(0.0)
    return VehicleState(x=x0 if i.x is None else i.x, y=y0 if i.y is None else i.y,
                        yaw=yaw0 if i.yaw is None else i.yaw, vx=i.speed)


def run(scenario: Scenario, realtime: float | None = None, compiled: bool = True,
        observers: Sequence[RunObserver] = (), started: float | None = None) -> RunResult:
    """Drive ``scenario`` to its end and score it; ``realtime`` paces it to that many times real time.

    Unpaced runs that qualify (:func:`~vilma.scenario.lockstep.compiled_ok`) run compiled, unless
    ``compiled`` is False; the drive is the same either way (reactive traffic too: its IDM steps in compiled
    code each driver period, in either loop). The ``observers`` watch it as it
    goes (the run's folder, its recording, a live view: :class:`~vilma.scenario.result.RunObserver`); the runner
    writes no file itself. ``started`` is the :func:`time.perf_counter` reading the run's share of the
    command began at (``wall_time_s``; default: now).

    Raises:
        SpecError: the scenario's files cannot be used (a bad trajectory file, an impossible order).
        Interrupted: Ctrl-C; the observers were told (:meth:`~vilma.scenario.result.RunObserver.failed`).
    """
    started = time.perf_counter() if started is None else started
    loading = LoadTimer()
    with install_listener("numba:compiler_lock", loading), failing(observers):
        car = Car(scenario, scenario.reference_path(), observers)
        with Simulator(car.config, car.initial) as sim:  # the 3D plant's renderers are freed however it ends
            try:
                result = car.drive(sim, realtime, compiled, loading)
            except KeyboardInterrupt:
                raise Interrupted(sim.time_ns * 1e-9) from None
    return finish(result, observers, lambda: time.perf_counter() - started, loading.seconds)


@contextlib.contextmanager
def failing(observers: Sequence[RunObserver]) -> Iterator[None]:
    """Tell the ``observers`` when what runs inside fails (:meth:`~vilma.scenario.result.RunObserver.failed`)."""
    try:
        yield
    except BaseException as e:
        for o in observers:
            o.failed(isinstance(e, KeyboardInterrupt))
        raise


def finish(result: RunResult, observers: Sequence[RunObserver], wall: Callable[[], float],
           load: float) -> RunResult:
    """Add the timing keys (``wall()`` [s] the run's share of the command so far, ``load`` [s] of loading compiled
    code) and hand the result to the ``observers``; returns it."""
    m = result.metrics

    def clock_out() -> None:
        m.update(timing(m["sim_time_s"], wall(), m["loop_wall_time_s"], load))

    clock_out()  # the observers see the time so far
    try:
        for o in observers:
            o.finished(result)
    finally:
        for o in observers:
            o.close()
    clock_out()
    return result


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a run: where the sim clock was [s] and where the partial files are."""

    def __init__(self, t: float, out_dir: Path | None = None) -> None:
        super().__init__(f"interrupted at t={t:.2f} s" + (f": partial files in {out_dir}" if out_dir else ""))
        self.t = t


class LoadTimer(TimingListener):
    """Wall time [s] spent loading (or compiling) numba code: under numba's compiler lock (numba's event API)."""

    @property
    def seconds(self) -> float:
        return self.duration if self.done else 0.0


class Car:
    """One scenario's run: its self-driver and simulator settings, then (:meth:`start`) its simulator, log and first
    readings, its task given; the loop that drives it, and the scorecard.

    ``path`` is the scenario's :meth:`~vilma.scenario.spec.Scenario.reference_path` (cars of one scenario share
    it).
    """

    def __init__(self, scenario: Scenario, path: Trajectory | None, observers: Sequence[RunObserver] = ()) -> None:
        self.scenario, self.path, self.observers = scenario, path, observers
        self.driver = Driver(scenario.sim.vehicle, scenario.driver, step=scenario.sim.step)
        self.capacity = round(scenario.duration / self.driver.period) + 2  # a row a period, allocated once
        self.config = sim_config(scenario, self.capacity)
        """The simulator's settings: the caller opens the :class:`Simulator` with them, at :attr:`initial`."""
        self.initial = initial_state(scenario, path)
        """Where the car starts."""
        self.periods, self.t_start = 0, 0.0
        self.planning = None
        """A plan task's perception and planning (:class:`~vilma.scenario.planned.Planning`), once it began."""

    def start(self, sim: Simulator) -> None:
        """Drive the car on ``sim`` (opened with :attr:`config` at :attr:`initial`, as it starts) with a new log; the
        observers start."""
        self.sim = sim
        self.log = DriveLog(capacity=self.capacity)
        for o in self.observers:
            o.started(sim, self.log)

    def begin(self, compiled: bool = True) -> None:
        """Take the first readings (the estimator starts) and give the driver its task; :attr:`periods` are then
        left to drive. With ``compiled``, the first period runs in the compiled loop where the loop may run
        (:func:`compiled_ok`), as the periods after it will: the simulator's frame then never runs (a second of a
        fresh install's first run), nor does a compiled step load for that one period."""
        s, sim, period = self.scenario, self.sim, self.driver.period_ticks
        if compiled and compiled_ok(sim, self.driver):  # (a plan's too: its driver has no plan task yet)
            CompiledDrive(sim, self.driver, self.log, 1, False, self.on_block).block()  # readings made, as in step
        else:
            self.step(sim.advance(period))
        task = start_task(self.driver, s, self.path)
        self.t_start = sim.time_ns * 1e-9
        if task is not None:
            self.path = task
        if s.task.kind == "plan":
            from vilma.scenario.planned import Planning  # perception and planning: for a plan only

            self.planning = Planning(s, self.path, self.driver, sim.config, observed=bool(self.observers))
            self.planning.cycle(self.t_start)
            self.hand_on()
        self.periods = round((s.duration - self.t_start) / (period * sim.clock.step_s))

    @property
    def follows(self) -> bool:
        """Whether the task ends at rest at the end of a path (not a speed task)."""
        return self.scenario.task.kind != "speed"

    @property
    def block_taker(self) -> Callable[[dict[str, Readings]], None] | None:
        """:meth:`on_block` for the compiled loop, None when it has nothing to hand them to (no observer; a plan,
        whose perception takes captures, runs in Python): its sensors then measure nothing."""
        return self.on_block if self.observers else None

    def on_block(self, readings: dict[str, Readings]) -> None:
        """Hand a block's readings and the 3D plant's captures to the observers."""
        for o in self.observers:
            o.add(readings)
        captures = self.sim.take_captures()  # camera images, laser scans, object lists: handed on, never kept
        for o in self.observers if captures else ():
            o.add_captures(captures)
        if self.planning is not None and captures:
            z = self.sim.plant
            self.planning.perceive(captures, self.driver.estimator.estimate, (z[X], z[Y], z[YAW]))

    def step(self, readings: dict[str, Readings]) -> None:
        """One driver period in Python: the driver takes the readings, its command goes to the car, a log row."""
        sim, driver = self.sim, self.driver
        t0 = time.perf_counter()
        cmd = driver.update(readings)
        spent = (time.perf_counter() - t0) * 1e6
        if cmd is not None:
            sim.command(cmd)
        z, st, est = sim.plant, driver.status, driver.estimator.estimate
        self.log.add((sim.time_ns * 1e-9, *z, st.target_speed, st.speed,
                      *((est.x, est.y, est.yaw) if est is not None else (math.nan,) * 3),
                      *((cmd.steer, cmd.drive, cmd.brake) if cmd is not None else (math.nan,) * 3), spent))
        self.on_block(readings)
        if self.planning is not None:
            self.planning.period_done(sim.time_ns * 1e-9)
            self.hand_on()

    def hand_on(self) -> None:
        """Hand the planning's new tracks and plans to the observers (as the 3D plant's captures: never kept)."""
        messages, self.planning.messages = self.planning.messages, []
        for o in self.observers if messages else ():
            o.add_captures(messages)

    def finished(self) -> bool:
        """Whether the task is done: arrived at the end of its path (a plan: at its goal), at rest."""
        z, s = self.sim.plant, self.scenario
        return self.follows and self.driver.state.arrived and abs(z[VX]) < s.driver.rest_speed and (
            self.planning is None or self.planning.at_goal(z[X], z[Y], s.metrics.end_tolerance))

    def drive(self, sim: Simulator, realtime: float | None, compiled: bool, loading: LoadTimer) -> RunResult:
        """The run of :func:`run` on ``sim``: start, step until the task is done or time is up, score."""
        self.start(sim)
        wall0, load0 = time.perf_counter(), loading.seconds
        self.begin(realtime is None and compiled)
        self.loop(realtime, compiled)
        return self.score(time.perf_counter() - wall0 - (loading.seconds - load0))

    def loop(self, realtime: float | None, compiled: bool) -> None:
        """After :meth:`begin`: step until the task is done or time is up, compiled if it may (see :func:`run`)."""
        sim, driver, period = self.sim, self.driver, self.driver.period_ticks
        if realtime is None and compiled and compiled_ok(sim, driver, planned=self.planning is not None):
            if self.planning is not None:
                self.loop_planned()
            else:
                run_compiled(sim, driver, self.log, self.periods, self.follows, self.block_taker)
        elif realtime is None:
            for _ in range(self.periods):
                if self.finished():
                    break
                self.step(sim.advance(period))
        else:
            Pacer(sim, speed=realtime, period=period * sim.clock.step_s).run(
                self.scenario.duration - self.t_start, on_period=self.step, should_stop=self.finished)

    def loop_planned(self) -> None:
        """:meth:`loop` of a plan, compiled up to each planning cycle and each scan (the Python loop's events: the
        blocks end on them, the tracks and plans are made as it makes them, the drive is the same)."""
        sim, planning, period = self.sim, self.planning, self.driver.period_ticks
        drive = CompiledDrive(sim, self.driver, self.log, self.periods, self.follows, self.on_block)
        while drive.done < self.periods and not self.finished():  # (not drive.running: a stop short of the goal)
            tick = sim.clock.tick  # to the end of the period of each scene sensor's next scan, and of the next cycle
            scans = [-(-((tick // p + 1) * p - tick) // period) for p in sim.scene_periods.tolist()]
            for _ in range(drive.block(min(planning.every - planning.periods % planning.every, *scans))):
                planning.period_done(sim.time_ns * 1e-9)
            self.hand_on()

    def score(self, loop: float) -> RunResult:
        """The result: the scorecard (against the traffic where it drove when it is ``reactive``) with ``loop`` [s]
        the loop's wall time."""
        scenario, sim = self.scenario, self.sim
        if sim.config.reactive is not None:
            scenario = dataclasses.replace(scenario, road=sim.config.reactive.task(scenario.road))
        metrics = scorecard(self.log, scenario, self.path, self.t_start,
                            broke_down=WATCHDOG_STOP if sim.watchdog_tripped else None)
        metrics.update(loop_wall_time_s=loop)
        if self.planning is not None:
            metrics.update((k, plain(v)) for k, v in self.planning.scores().items())
        if scenario.road is None and sim.config.model == MUJOCO:  # else the benchmark's or flat ground's (scorecard)
            metrics["collisions"] = sim.collisions[0]
        return RunResult(scenario, metrics, expectation_failures(metrics, scenario), self.log, self.path,
                         self.t_start, planning=self.planning.log if self.planning is not None else None)


def sim_config(scenario: Scenario, periods: int | None = None) -> SimConfig:
    """The simulator of ``scenario``: with ``traffic: reactive``, its road's traffic driven by IDM at the driver
    period, for ``periods`` of them (None: open-ended, :class:`~vilma.world.reactive.ReactiveTraffic`)."""
    if scenario.traffic != "reactive":
        return scenario.sim
    from vilma.world.reactive import ReactiveTraffic  # the roads extra, there when the scenario is a road

    road, sim = scenario.road, scenario.sim
    period = Driver(sim.vehicle, scenario.driver, step=sim.step).period
    reactive = ReactiveTraffic(road.traffic, road.time_step * road.dt, period, periods, sim.vehicle.length)
    return dataclasses.replace(sim, traffic=reactive.traffic, traffic_t0=0.0, reactive=reactive)


def start_task(driver: Driver, scenario: Scenario, path: Trajectory | None) -> Trajectory | None:
    """Give the driver its task; returns the path it drives when it makes one (go to a point)."""
    t = scenario.task
    try:
        if t.kind == "plan":
            return None  # the plan's cycles drive it (Planning)
        if t.kind == "speed":
            driver.set_speed(t.speed)
        elif t.kind == "go_to":
            driver.go_to(*t.go_to, t.speed)
            return driver.task.path
        else:
            driver.follow(path, None if t.kind == "route" else t.speed)  # a route's speeds are its lanelets' limits
    except ValueError as e:
        raise SpecError(f"{scenario.file or scenario.name}: task: {e}") from None
    return None
