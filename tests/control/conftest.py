"""Closed-loop helpers: the simulator and the self-driver on one loop, as the scenario runner will wire them."""

from __future__ import annotations

from dataclasses import dataclass
from importlib.resources import files

import numpy as np

from vilma.control.driver import Driver, DriverParams
from vilma.sim import SimConfig, Simulator
from vilma.trajectory import Trajectory, increase_point_count, load_trajectory, smooth_iterative
from vilma.vehicle.state import VehicleState

LOGS = files("vilma") / "scenarios" / "data"
"""The original's recorded logs, as the package ships them (what a user's install reads)."""


@dataclass
class Run:
    """What a closed-loop drive did: truth poses at each driver period, and the driver."""

    t: np.ndarray
    xy: np.ndarray
    speed: np.ndarray
    cross_track: np.ndarray
    driver: Driver
    sim: Simulator

    @property
    def rms(self) -> float:
        return float(np.sqrt(np.mean(self.cross_track**2)))


def start_of(path: Trajectory) -> VehicleState:
    """At rest on the first point, facing along the path."""
    x, y = path.xy[0]
    return VehicleState(x=float(x), y=float(y), yaw=float(path.heading_at(0.0)))


def drive_path(path: Trajectory, speed: float, params: DriverParams, seconds: float = 200.0,
               config: SimConfig | None = None) -> Run:
    """Follow ``path`` at ``speed`` from rest on its first point until the driver has stopped at the end."""
    sim = Simulator(config or SimConfig())
    sim.reset(start_of(path))
    driver = Driver(sim.config.vehicle, params, step=sim.config.step)
    driver.update(sim.run_for(driver.period))
    driver.follow(path, speed)
    t, xy, v, e = [], [], [], []
    for _ in range(round(seconds / driver.period)):
        cmd = driver.update(sim.advance(driver.period_ticks))
        if cmd is not None:
            sim.command(cmd)
        s = sim.state
        t.append(sim.time_ns / 1e9)
        xy.append((s.x, s.y))
        v.append(s.speed)
        e.append(path.project(s.x, s.y).cross_track)
        if driver.status.arrived and s.speed < 0.01:
            break
    return Run(np.array(t), np.array(xy), np.array(v), np.array(e), driver, sim)


def curved_log() -> Trajectory:
    """The original's recorded curved drive after Generate Points and Smooth Trajectory, as the paper did."""
    path = load_trajectory(LOGS / "PositionLog_curved.txt")
    return Trajectory.from_points(smooth_iterative(increase_point_count(path).xy))
