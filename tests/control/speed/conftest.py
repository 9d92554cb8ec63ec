"""A straight-line speed loop on the simulator (no path controller)."""

from __future__ import annotations

import numpy as np

from vilma.control.driver import LONGITUDINAL
from vilma.control.registry import Controller
from vilma.core.messages import ActuatorCommand
from vilma.sim import SimConfig, Simulator


def speed_run(ctrl: Controller, target: float, seconds: float = 40.0, delay: bool = False,
              original_speed: bool = False):
    """Drive straight from rest holding ``target``; returns (t, measured speed) at each control period.

    ``delay`` sends each command one period late (the original's sleep-then-send);
    ``original_speed`` measures sqrt(vx^2 + vy^2 + wz^2) as the original.
    """
    sim = Simulator(SimConfig())
    ctrl.reset()
    pending, speed, t, v = None, 0.0, [], []
    for _ in range(round(seconds / ctrl.period)):
        mode, drive, brake, limit = ctrl.step(target, speed, 0.0)
        cmd = ActuatorCommand(longitudinal=LONGITUDINAL[mode], drive=drive, brake=brake, velocity_limit=limit,
                              autonomous=True)
        if delay:
            if pending is not None:
                sim.command(pending)
            pending = cmd
        else:
            sim.command(cmd)
        m = sim.run_for(ctrl.period)["velocity"].latest()
        speed = np.sqrt(m.vx_world**2 + m.vy_world**2 + m.wz**2) if original_speed else m.speed
        t.append(sim.time_ns / 1e9)
        v.append(speed)
    return np.array(t), np.array(v)


def time_to(t: np.ndarray, v: np.ndarray, level: float) -> float:
    """First time [s] the speed reaches ``level``, interpolated between samples."""
    i = int(np.argmax(v >= level))
    assert v[i] >= level, "never reached"
    if i == 0:
        return float(t[0])
    return float(t[i - 1] + (level - v[i - 1]) / (v[i] - v[i - 1]) * (t[i] - t[i - 1]))
