"""The closed loop compiled: plant, driver and log in one numba loop, the sensors measured per block.

:func:`run_compiled` does what the runner's Python loop does (advance one
driver period, give the driver the exact pose, apply its command, log a row)
with every period in compiled code, so a drive runs over a thousand times
faster than real time. The sensors still sample the plant at their rates:
the loop records the plant at their sample ticks and they measure it after
each block, exactly as the simulator would have.

It applies when the driver steers by the simulator's exact pose, as read by
the noise-free ``pose`` and ``velocity`` sensors at least once a driver
period, or by the EKF (the loop measures and fuses its sensors each period:
:mod:`vilma.scenario.lockstep_ekf`), without actuator dead time;
:func:`compiled_ok` says whether a run qualifies, and the runner falls back to
the Python loop otherwise. Both loops give bit-identical drives (tested).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np
from numba import njit

from vilma.control.driver import Driver, DriverMode, aimed_speed, driver_step
from vilma.core.geometry import wrap
from vilma.core.messages import PoseEstimate
from vilma.localization import Ekf, TruthEstimator
from vilma.scenario.drive_log import COLUMNS, DriveLog
from vilma.scenario.lockstep_ekf import block_inputs, ekf_ok, ekf_period
from vilma.sensors import Readings
from vilma.sim import Simulator
from vilma.sim.simulator import KernelResult, PlantKernel
from vilma.vehicle.actuators import clamp_command
from vilma.vehicle.integrate import advance
from vilma.vehicle.state import VX, VY, YAW, YAW_RATE, X, Y
from vilma.world.idm import idm_step

BLOCK = 1024
"""Driver periods per compiled call (the sensors measure and the log grows once a block)."""


def _truth_periods(sim: Simulator) -> tuple[int, int]:
    """Sample periods [ticks] of the pose and velocity sensors (1 for one that is not there)."""
    s = sim.config.sensors
    return tuple(1 if p is None else sim.clock.period_ticks(p.rate_hz, "sensor") for p in (s.pose, s.velocity))


def compiled_ok(sim: Simulator, driver: Driver, planned: bool = False) -> bool:
    """Whether :func:`run_compiled` reproduces the Python loop for this simulator and driver.

    The driver must steer either by the exact pose, the pose and velocity sensors noise-free and sampling at
    driver period ends (their period a divisor or a multiple of the driver's), or by the EKF with the IMU,
    wheel speeds and GPS on the car and its speed (not the original's formula); the actuators have no
    dead time, the watchdog not fire between two periods, and reactive traffic step at the driver period; a
    driver on a planner's local trajectories needs the Python loop (the planner replans between its periods) but
    when ``planned``: the caller runs it up to each cycle and scan only (:meth:`~vilma.scenario.runner.Car.loop`).
    """
    p, r = driver.period_ticks, sim.config.reactive
    wd = sim.clock.ticks_for(sim.config.watchdog_timeout)
    return (planned or driver.task.mode != DriverMode.PLAN) and sim.compiled_ok and _source_ok(sim, driver) and \
        (wd == 0 or wd > p) and (r is None or sim.clock.ticks_for(r.period) == p)


def _source_ok(sim: Simulator, driver: Driver) -> bool:
    """Whether the loop reads the pose as the driver's estimator does (:func:`compiled_ok`)."""
    if driver.params.pose_source == "ekf":
        return ekf_ok(sim) and not driver.params.original_speed
    pose, vel = sim.config.sensors.pose, sim.config.sensors.velocity
    if driver.params.pose_source != "truth" or pose is None or vel is None:
        return False
    if pose.position_noise or pose.yaw_noise or vel.linear_noise or vel.angular_noise:
        return False
    p = driver.period_ticks
    return all(p % t == 0 or t % p == 0 for t in _truth_periods(sim))


@njit(cache=True, nogil=True)  # cars of a fleet run side by side in threads
def _loop(model, integrator, z, pc, dt, step_ns, tick, periods, out_z, out_dx, out_tick, n, cmd_mode, cmd, limits,
          dc, ds, pa, has_path, speed_c, speed_s, path_c, path_s, original_speed, stop_at_rest, rows, truth,
          pose_period, vel_period, traffic, body_offset, ekf):
    """Up to ``n`` driver periods; returns (periods run, sensor records written, arrived at rest).

    The driver steers by the exact pose (``ekf`` None: ``truth`` = ``[speed, yaw rate]`` of the latest velocity
    reading, as :class:`TruthEstimator` keeps it) or by the EKF (``ekf``: :class:`~.lockstep_ekf.EkfLoop`).
    ``traffic`` (:class:`~vilma.world.idm.IdmArrays`, or None) steps a period at each period's end, seeing the ego's box
    centre ``body_offset`` [m] ahead of its reference point, as :meth:`Simulator.advance` does.
    """
    j = 0
    for k in range(n):
        m = advance(model, integrator, z, cmd_mode[0], cmd, pc, dt, dc.period_ticks, tick, periods, out_z[j:],
                    out_dx[j:], out_tick[j:])
        tick += dc.period_ticks
        if ekf is None:
            _read_truth(z, tick, ds, truth, pose_period, vel_period, original_speed)
        else:
            ekf_period(ekf, out_z[j:j + m], out_dx[j:j + m], out_tick[j:j + m], tick - dc.period_ticks, tick, ds)
        j += m
        sent = driver_step(dc, ds, pa, has_path, speed_c, speed_s, path_c, path_s)
        r = rows[k]
        r[0] = (tick * step_ns) * 1e-9
        for i in range(9):  # element by element: a slice copy compiles its shape check's message
            r[1 + i] = z[i]
        r[10] = aimed_speed(dc, ds, pa)
        r[11] = ds.measured
        r[12], r[13], r[14] = (ds.x, ds.y, ds.yaw) if ds.has_pose else (math.nan, math.nan, math.nan)
        if sent:
            mode = ds.command_mode
            cmd[0], cmd[1], cmd[2], cmd[3] = ds.steer, ds.drive, ds.brake, ds.velocity_limit
            r[15], r[16], r[17] = cmd[0], cmd[1], cmd[2]  # as the driver sent it, before the car clamps it
            clamp_command(limits, mode, cmd)
            cmd_mode[0] = mode
        else:
            r[15] = r[16] = r[17] = math.nan
        if traffic is not None:  # pruned when compiled without (no IDM to compile for a run without traffic)
            idm_step(traffic, z[X] + body_offset * math.cos(z[YAW]), z[Y] + body_offset * math.sin(z[YAW]), z[VX])
        if stop_at_rest and ds.arrived and abs(z[VX]) < dc.rest_speed:
            return k + 1, j, True
    return n, j, False


@njit(cache=True)
def _read_truth(z, tick, ds, truth, pose_period, vel_period, original_speed):
    """What :class:`TruthEstimator` makes of the pose and velocity sensors (they sample at period ends only)."""
    velocity_read = tick % vel_period == 0
    if velocity_read:
        truth[0], truth[1] = z[VX], z[YAW_RATE]
    if tick % pose_period == 0:
        ds.has_pose, ds.x, ds.y, ds.yaw = True, z[X], z[Y], wrap(z[YAW])
        ds.pose_speed, ds.yaw_rate = truth[0], truth[1]
    if ds.has_pose:
        if original_speed and velocity_read:  # sqrt(vx^2 + vy^2 + wz^2), world frame, as the original
            c, s = math.cos(z[YAW]), math.sin(z[YAW])
            wx, wy = z[VX] * c - z[VY] * s, z[VX] * s + z[VY] * c
            ds.measured = math.sqrt(wx * wx + wy * wy + z[YAW_RATE] ** 2)
        else:
            ds.measured = ds.pose_speed


def _catch_up(est: TruthEstimator, ds: np.record, truth: np.ndarray, stamp_ns: int) -> None:
    """Leave the estimator as the Python loop would have: latest velocity reading and pose."""
    est.speed, est.yaw_rate = float(truth[0]), float(truth[1])
    if ds["has_pose"]:  # by item: a record's attributes cost a planned run's short blocks more
        est.estimate = PoseEstimate(stamp_ns, float(ds["x"]), float(ds["y"]), float(ds["yaw"]),
                                    float(ds["pose_speed"]), float(ds["yaw_rate"]), 0.0, 0.0, 0.0)


class CompiledDrive:
    """One car's drive in the compiled loop, a block of driver periods at a time (:func:`run_compiled`; a fleet
    interleaves the blocks of many cars: :mod:`vilma.scenario.fleet`).

    Without ``on_block`` (nobody takes the readings) the sensors make none, unless the EKF steers.

    :meth:`start` gives the arguments of :func:`_loop` for the next block; whoever calls it with them hands its
    return value to :meth:`end`, which appends the block's rows to ``log`` and gives ``on_block`` its readings.
    """

    def __init__(self, sim: Simulator, driver: Driver, log: DriveLog, periods: int, stop_at_rest: bool,
                 on_block: Callable[[dict[str, Readings]], None] | None = None) -> None:
        self.sim, self.driver, self.log, self.periods, self.stop_at_rest = sim, driver, log, periods, stop_at_rest
        self.on_block = on_block
        est = driver.estimator
        self.ekf = isinstance(est, Ekf)
        self.truth = np.zeros(2) if self.ekf else np.array([est.speed, est.yaw_rate])
        self.truth_periods = _truth_periods(sim)
        self.rows = np.empty((BLOCK, len(COLUMNS)))
        self.done, self.stopped = 0, False
        self._kernel: PlantKernel | None = None

    @property
    def running(self) -> bool:
        """Whether periods are left and the car has not stopped at rest."""
        return self.done < self.periods and not self.stopped

    def start(self, most: int = BLOCK) -> tuple:
        """The arguments of :func:`_loop` for up to ``most`` periods (at most a block) from where the simulator is."""
        sim, driver = self.sim, self.driver
        self._kernel = p = sim.kernel_start(BLOCK * driver.period_ticks, sensing=self.ekf or self.on_block is not None)
        n = min(most, BLOCK, self.periods - self.done)
        e = block_inputs(sim, driver.estimator, p.tick, n * driver.period_ticks) if self.ekf else None
        return (p.model, p.integrator, p.z, p.consts, p.step, p.step_ns, p.tick, p.periods, *p.records, n, p.mode,
                p.cmd, p.limits, *driver.step_args(), driver.params.original_speed, self.stop_at_rest, self.rows,
                self.truth, *self.truth_periods, p.traffic, sim.config.vehicle.body_offset, e)

    def block(self, most: int = BLOCK) -> int:
        """Run up to ``most`` periods (at most a block) from where the simulator is: :meth:`start`, :func:`_loop`
        and :meth:`end`; the periods run."""
        args = self.start(most)
        wall = time.perf_counter()
        ran = _loop(*args)
        self.end(ran, time.perf_counter() - wall)
        return ran[0]

    def end(self, ran: tuple[int, int, bool], wall: float) -> None:
        """Take the block :func:`_loop` ran: ``ran`` its return value, ``wall`` [s] the wall time it took."""
        k, m, self.stopped = ran
        sim, driver, p, rows = self.sim, self.driver, self._kernel, self.rows
        rows[:k, -1] = wall / k * 1e6
        sent = np.flatnonzero(~np.isnan(rows[:k, 15]))
        commanded = p.tick + driver.period_ticks * int(sent[-1] + 1) if len(sent) else None
        readings = sim.kernel_end(p, KernelResult(k * driver.period_ticks, m, commanded))
        est = driver.estimator
        if self.ekf:
            if est.refresh() is not None:  # the estimate and the driver's stamp as Driver.update leaves them
                driver.stamp_ns = est.estimate.stamp_ns
        else:
            driver.stamp_ns = sim.clock.step_ns * sim.clock.tick
            pose_period = self.truth_periods[0]
            _catch_up(est, driver.state, self.truth, sim.clock.step_ns * (p.tick // pose_period * pose_period))
        self.log.extend(rows[:k])
        if self.on_block is not None:
            self.on_block(readings)
        self.done += k
        self._kernel = None


def run_compiled(sim: Simulator, driver: Driver, log: DriveLog, periods: int, stop_at_rest: bool,
                 on_block: Callable[[dict[str, Readings]], None] | None = None) -> bool:
    """Run up to ``periods`` driver periods compiled, appending a log row each; True if it stopped at rest.

    ``on_block`` gets the sensor readings of each block (after its rows are in the log; without it, and without
    the EKF, the sensors make none). The simulator's reactive
    traffic (:attr:`PlantKernel.traffic <vilma.sim.simulator.PlantKernel.traffic>`) steps each period. The column
    ``controller_us`` holds the wall time per period of the whole compiled loop (plant, driver and
    log): an upper bound of the driver's cost.
    """
    drive = CompiledDrive(sim, driver, log, periods, stop_at_rest, on_block)
    while drive.running:
        drive.block()
    return drive.stopped
