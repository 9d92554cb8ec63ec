"""Run a scenario headless: the simulator and the self-driver in lockstep, then the scorecard and the files.

The driver runs at its own period (the gcd of its controllers' periods); each
period the simulator advances that many physics steps, the driver takes the
readings and its command applies from the next step. Lockstep runs as fast as
the machine allows; ``realtime`` paces it with :class:`~vilma.sim.Pacer`.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba.core.event import TimingListener, install_listener

from vilma.control.driver import Driver
from vilma.core.files import write_atomic
from vilma.scenario.drive_log import DriveLog, TimeseriesWriter
from vilma.scenario.fields import SpecError
from vilma.scenario.lockstep import compiled_ok, run_compiled
from vilma.scenario.metrics import WATCHDOG_STOP, expectation_failures, scorecard, timing
from vilma.scenario.spec import Scenario, beside, to_yaml
from vilma.sensors import Readings
from vilma.sim import Pacer, Simulator
from vilma.trajectory import Trajectory, load_speed_log
from vilma.vehicle.state import VX, VehicleState


@dataclass
class RunResult:
    """A finished run: the scenario, the scorecard and what it failed, the log, where the files are."""

    scenario: Scenario
    metrics: dict
    failures: list[str]
    log: DriveLog
    path: Trajectory | None
    """The reference path (for a go-to task: the straight line the driver took)."""
    t_start: float
    """Sim time the task began [s]."""
    out_dir: Path | None = None

    @property
    def passed(self) -> bool:
        """Whether the run met its ``expect`` block (and finished its task)."""
        return not self.failures


def initial_state(scenario: Scenario, path: Trajectory | None) -> VehicleState:
    """The start: the ``initial`` block, else the path's first point facing along it, else the origin."""
    i = scenario.initial
    x0, y0, yaw0 = 0.0, 0.0, 0.0
    if path is not None:
        x0, y0 = (float(v) for v in path.xy[0])
        yaw0 = path.heading_at(0.0)
    return VehicleState(x=x0 if i.x is None else i.x, y=y0 if i.y is None else i.y,
                        yaw=yaw0 if i.yaw is None else i.yaw, vx=i.speed)


def run(scenario: Scenario, realtime: float | None = None, out_dir: Path | None = None,
        compiled: bool = True, record: bool = True,
        observe: Callable[[dict[str, Readings]], None] | None = None, started: float | None = None) -> RunResult:
    """Drive ``scenario`` to its end; ``realtime`` paces it to that many times real time.

    Unpaced runs that qualify (:func:`~vilma.scenario.lockstep.compiled_ok`) run compiled, unless
    ``compiled`` is False; the drive is the same either way.

    With ``out_dir``, the run's files go there (:func:`write_outputs`), the timeseries and the recording
    ``run.mcap`` (:mod:`vilma.record.run`, unless ``record`` is False) streamed as it runs. ``observe`` gets
    the sensor readings as they are made (a live view). ``started`` is the :func:`time.perf_counter` reading
    the run's share of the command began at (``wall_time_s``; default: now).

    Raises:
        SpecError: the scenario's files cannot be used (a bad trajectory file, an impossible order).
        Interrupted: Ctrl-C; the files so far are kept, the recording finished.
    """
    started = time.perf_counter() if started is None else started
    loading = _LoadTimer()
    with install_listener("numba:compiler_lock", loading):
        return _run(scenario, realtime, out_dir, compiled, record, observe, started, loading)


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during a run: where the sim clock was and where the partial files are."""

    def __init__(self, t: float, out_dir: Path | None) -> None:
        super().__init__(f"interrupted at t={t:.2f} s" + (f": partial files in {out_dir}" if out_dir else ""))


class _LoadTimer(TimingListener):
    """Wall time [s] spent loading (or compiling) numba code: under numba's compiler lock (numba's event API)."""

    @property
    def seconds(self) -> float:
        return self.duration if self.done else 0.0


def _run(scenario: Scenario, realtime: float | None, out_dir: Path | None, compiled: bool, record: bool,
         observe, started: float, loading: _LoadTimer) -> RunResult:
    path = scenario.reference_path()
    sim = Simulator(scenario.sim)
    sim.reset(initial_state(scenario, path))
    driver = Driver(sim.config.vehicle, scenario.driver, step=sim.config.step)
    log = DriveLog(capacity=round(scenario.duration / driver.period) + 2)  # a row a period, allocated once
    series = rec = on_block = None
    if out_dir is not None:
        from vilma.record.run import RUN_FILE, RunRecorder  # the recording only when files are written

        out_dir.mkdir(parents=True, exist_ok=True)
        series = TimeseriesWriter(out_dir / "timeseries.csv", sim.sensors, log)
        rec = RunRecorder(out_dir / RUN_FILE, scenario, log) if record else None

        def on_block(readings: dict[str, Readings]) -> None:
            series.add(readings)
            if rec is not None:
                rec.add(readings)
            if observe is not None:
                observe(readings)
    elif observe is not None:
        on_block = observe

    def step(readings: dict[str, Readings]) -> None:
        t0 = time.perf_counter()
        cmd = driver.update(readings)
        spent = (time.perf_counter() - t0) * 1e6
        if cmd is not None:
            sim.command(cmd)
        z, st, est = sim.plant, driver.status, driver.estimator.estimate
        log.add((sim.time_ns * 1e-9, *z, st.target_speed, st.speed,
                 *((est.x, est.y, est.yaw) if est is not None else (math.nan,) * 3),
                 *((cmd.steer, cmd.drive, cmd.brake) if cmd is not None else (math.nan,) * 3), spent))
        if on_block is not None:
            on_block(readings)
        captures = sim.take_captures()  # camera images and laser scans (3D plant): recorded, never kept
        if captures and rec is not None:
            rec.add_captures(captures)

    try:
        result = _drive(scenario, sim, driver, log, path, step, on_block, realtime, compiled, loading)
    except KeyboardInterrupt:
        if series is not None:  # keep what was made: the timeseries so far, the recording finished
            series.close()
            if rec is not None:
                rec.abort()
        raise Interrupted(sim.time_ns * 1e-9, out_dir) from None
    except BaseException:
        if series is not None:
            series.abort()
            if rec is not None:
                rec.abort()
        raise
    finally:
        sim.close()
    m = result.metrics

    def clock_out() -> None:
        m.update(timing(m["sim_time_s"], time.perf_counter() - started, m["loop_wall_time_s"], loading.seconds))

    if series is not None:
        if rec is not None:
            clock_out()  # the recording's scorecard has the time so far
            rec.finish(result)  # the recorder's process finishes the file while the plots are drawn
        try:
            series.close()
            write_outputs(result, out_dir)
        finally:
            if rec is not None:
                rec.close()
    clock_out()
    if out_dir is not None:
        write_metrics(result, out_dir)  # last: a folder with metrics.json holds a whole run
    return result


def _drive(scenario: Scenario, sim: Simulator, driver: Driver, log: DriveLog, path: Trajectory | None, step,
           on_block, realtime: float | None, compiled: bool, loading: _LoadTimer) -> RunResult:
    """The loop of :func:`run`: start the task, step until it is done or time is up, score."""
    period = driver.period_ticks
    wall0, load0 = time.perf_counter(), loading.seconds
    step(sim.advance(period))  # the first readings: the estimator starts
    task = start_task(driver, scenario, path)
    t_start = sim.time_ns * 1e-9
    if task is not None:
        path = task
    follows = scenario.task.kind != "speed"

    def finished() -> bool:
        return follows and driver.status.arrived and abs(sim.plant[VX]) < scenario.driver.rest_speed

    remaining = scenario.duration - t_start
    periods = round(remaining / (period * sim.clock.step_s))
    if realtime is None and compiled and compiled_ok(sim, driver):
        run_compiled(sim, driver, log, periods, follows, on_block)
    elif realtime is None:
        for _ in range(periods):
            if finished():
                break
            step(sim.advance(period))
    else:
        Pacer(sim, speed=realtime, period=period * sim.clock.step_s).run(remaining, on_period=step,
                                                                         should_stop=finished)
    loop = time.perf_counter() - wall0 - (loading.seconds - load0)
    metrics = scorecard(log, scenario, path, t_start, broke_down=WATCHDOG_STOP if sim.watchdog_tripped else None)
    metrics.update(collisions=sim.collisions[0], loop_wall_time_s=loop)
    return RunResult(scenario, metrics, expectation_failures(metrics, scenario), log, path, t_start)


def start_task(driver: Driver, scenario: Scenario, path: Trajectory | None) -> Trajectory | None:
    """Give the driver its task; returns the path it drives when it makes one (go to a point)."""
    t = scenario.task
    try:
        if t.kind == "speed":
            driver.set_speed(t.speed)
        elif t.kind == "go_to":
            driver.go_to(*t.go_to, t.speed)
            return driver.task.path
        else:
            driver.follow(path, t.speed)
    except ValueError as e:
        raise SpecError(f"{scenario.file or scenario.name}: task: {e}") from None
    return None


# -- files -----------------------------------------------------------------------------------------------


def write_outputs(result: RunResult, out_dir: Path) -> Path:
    """Write ``scenario.yaml`` and the PNG plots into ``out_dir`` (the timeseries streams; :func:`write_metrics`
    comes last)."""
    from vilma.scenario.report import plot_run  # matplotlib only when files are written

    out_dir.mkdir(parents=True, exist_ok=True)
    write_atomic(out_dir / "scenario.yaml", to_yaml(result.scenario))
    plot_run(result, out_dir, speed_log(result.scenario))
    result.out_dir = out_dir
    return out_dir


def write_metrics(result: RunResult, out_dir: Path) -> Path:
    """``metrics.json``: the scorecard."""
    return write_atomic(out_dir / "metrics.json", json.dumps(result.metrics, indent=2) + "\n")


def speed_log(scenario: Scenario) -> tuple[np.ndarray, np.ndarray] | None:
    """The recorded speed log the scenario compares with (``speed_log`` beside the scenario), or None."""
    if scenario.speed_log is None:
        return None
    p = beside(scenario.file, scenario.speed_log)
    try:
        return load_speed_log(p)
    except (OSError, ValueError) as e:
        raise SpecError(f"{scenario.file or scenario.name}: speed_log: cannot read {p}: {e}") from None
