"""A short closed-loop demo drive on the simulator (until the scenario runner exists).

The car starts at rest, accelerates to 10 m/s, changes lane 3.5 m to the
left, and brakes to a stop. A proportional speed controller (``accel``
commands) and a heading controller toward the lane read the pose and
velocity sensors at 20 Hz, as a self-driver would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from vilma.core.geometry import wrap_angle
from vilma.core.messages import ActuatorCommand, Longitudinal, Pose, Velocity
from vilma.sensors import Readings
from vilma.sim import Pacer, SimConfig, Simulator

CONTROL_PERIOD = 0.05
"""Demo controller period [s]."""


@dataclass(frozen=True, slots=True)
class DemoRow:
    """One printed line of the demo."""

    t: float
    x: float
    y: float
    yaw: float
    speed: float
    steer: float
    phase: str


def _phase(t: float) -> tuple[str, float, float]:
    """Phase name, target speed [m/s] and target lane y [m] at time ``t`` [s]."""
    if t < 8.0:
        return "accelerate", 10.0, 0.0
    if t < 16.0:
        return "change lane", 10.0, 3.5
    return "brake", 0.0, 3.5


def drive(duration: float = 22.0, config: SimConfig | None = None, every: float = 1.0,
          speed: float | None = None) -> list[DemoRow]:
    """Run the demo, as fast as possible or paced to ``speed`` x real time; one row per ``every`` s of sim time."""
    sim = Simulator(config)
    latest: dict[str, Pose | Velocity] = {}
    rows: list[DemoRow] = []
    report_every = max(1, round(every / CONTROL_PERIOD))

    def control(readings: dict[str, Readings]) -> None:
        for name in ("pose", "velocity"):
            if name in readings:
                latest[name] = readings[name].latest()
        t = sim.time_ns / 1e9
        _, v_ref, y_ref = _phase(t)
        pose, vel = latest.get("pose"), latest.get("velocity")
        if pose is not None and vel is not None:
            accel = min(max(0.8 * (v_ref - vel.speed), -3.0), 2.0)
            heading_ref = math.atan(0.1 * (y_ref - pose.y))
            steer = 1.0 * wrap_angle(heading_ref - pose.yaw)
            sim.command(ActuatorCommand(stamp_ns=sim.time_ns, steer=max(-0.3, min(0.3, steer)),
                                        longitudinal=Longitudinal.ACCEL, drive=accel, autonomous=True))
        if round(t / CONTROL_PERIOD) % report_every == 0:
            s = sim.state
            rows.append(DemoRow(t, s.x, s.y, s.yaw, s.speed, s.steer, _phase(t - CONTROL_PERIOD)[0]))

    if speed is None:
        for _ in range(round(duration / CONTROL_PERIOD)):
            control(sim.run_for(CONTROL_PERIOD))
    else:
        Pacer(sim, speed=speed, period=CONTROL_PERIOD).run(duration, on_period=control)
    return rows


def format_rows(rows: list[DemoRow]) -> str:
    """The rows as a fixed-width table."""
    lines = [f"{'t [s]':>6} {'x [m]':>8} {'y [m]':>7} {'yaw [deg]':>9} {'speed [m/s]':>11} {'steer [deg]':>11}  phase"]
    lines += [f"{r.t:6.1f} {r.x:8.2f} {r.y:7.2f} {math.degrees(r.yaw):9.2f} {r.speed:11.2f} "
              f"{math.degrees(r.steer):11.2f}  {r.phase}" for r in rows]
    return "\n".join(lines)
