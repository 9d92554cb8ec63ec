"""A closed-loop demo drive (until the scenario runner exists).

The paper's car starts at rest on the paper-style course through (0, 0),
(100, 0), (100, -30), (50, -20), (60, 0) (a smooth spline), follows it at
30 km/h with the self-driver (by default ``pi_ff`` speed and ``stanley``
path control, from the exact pose), and stops on its last point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vilma.control.driver import Driver, DriverParams
from vilma.sensors import Readings
from vilma.sim import Pacer, SimConfig, Simulator
from vilma.trajectory.course import spline_course
from vilma.vehicle.state import VehicleState

COURSE_SPEED = 30 / 3.6
"""Set speed on the demo course [m/s]."""


@dataclass(frozen=True, slots=True)
class DemoRow:
    """One printed line of the demo: time [s], pose, speed [m/s], steer [rad], cross-track error [m]."""

    t: float
    x: float
    y: float
    yaw: float
    speed: float
    steer: float
    cross_track: float


@dataclass(frozen=True, slots=True)
class DemoResult:
    """The printed rows and the drive's figures."""

    rows: list[DemoRow]
    arrived: bool
    end_distance: float
    """From the car to the course's last point at the end [m]."""
    rms_cross_track: float
    max_cross_track: float
    sim_seconds: float


def drive(config: SimConfig | None = None, params: DriverParams | None = None, duration: float = 120.0,
          every: float = 2.0, speed: float | None = None) -> DemoResult:
    """Run the demo until the car stops at the end (or ``duration`` [s]); paced to ``speed`` x real time if given."""
    path = spline_course()
    sim = Simulator(config)
    x0, y0 = path.xy[0]
    sim.reset(VehicleState(x=float(x0), y=float(y0), yaw=path.heading_at(0.0)))
    driver = Driver(sim.config.vehicle, params, step=sim.config.step)
    driver.update(sim.advance(driver.period_ticks))
    driver.follow(path, COURSE_SPEED)
    rows: list[DemoRow] = []
    errors: list[float] = []
    report_ticks = max(1, round(every / sim.clock.step_s))

    def control(readings: dict[str, Readings]) -> None:
        cmd = driver.update(readings)
        if cmd is not None:
            sim.command(cmd)
        s = sim.state
        e = path.project(s.x, s.y).cross_track
        errors.append(e)
        if sim.clock.tick % report_ticks == 0:
            rows.append(DemoRow(sim.time_ns / 1e9, s.x, s.y, s.yaw, s.speed, s.steer, e))

    def done() -> bool:
        return driver.status.arrived and sim.state.speed < 0.01

    if speed is None:
        while sim.clock.time_s < duration and not done():
            control(sim.advance(driver.period_ticks))
    else:
        Pacer(sim, speed=speed, period=driver.period).run(duration, on_period=control, should_stop=done)
    s = sim.state
    e = np.asarray(errors)
    return DemoResult(rows, driver.status.arrived, math.hypot(s.x - path.xy[-1, 0], s.y - path.xy[-1, 1]),
                      float(np.sqrt(np.mean(e**2))), float(np.abs(e).max()), sim.time_ns / 1e9)


def format_rows(rows: list[DemoRow]) -> str:
    """The rows as a fixed-width table."""
    lines = [f"{'t [s]':>6} {'x [m]':>8} {'y [m]':>8} {'yaw [deg]':>9} {'speed [m/s]':>11} {'steer [deg]':>11} "
             f"{'off path [m]':>12}"]
    lines += [f"{r.t:6.1f} {r.x:8.2f} {r.y:8.2f} {math.degrees(r.yaw):9.1f} {r.speed:11.2f} "
              f"{math.degrees(r.steer):11.2f} {r.cross_track:12.3f}" for r in rows]
    return "\n".join(lines)
