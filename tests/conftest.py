"""Shared test helpers."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from vilma.core.messages import ActuatorCommand
from vilma.sensors import SensorSuite
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import NZ


@pytest.fixture(autouse=True)
def _root_log_level():
    """The root logger's level, put back after each test (``vilma.cli.main`` sets it from -v/-q)."""
    level = logging.getLogger().level
    yield
    logging.getLogger().setLevel(level)


STEP = SimConfig().step
"""The default physics step [s]."""


def drive(config: SimConfig, cmd: ActuatorCommand, seconds: float, initial=None) -> np.ndarray:
    """Hold ``cmd`` for ``seconds``; returns the plant vector after every step, shape (steps, NZ)."""
    sim = Simulator(config)
    if initial is not None:
        sim.reset(initial)
    sim.command(cmd)
    n = sim.clock.ticks_for(seconds)
    out = np.empty((n, NZ))
    for i in range(n):
        sim.step()
        out[i] = sim._z
    return out


def physics_only(**kw) -> SimConfig:
    """A config without sensors."""
    return SimConfig(sensors=SensorSuite.none(), **kw)


def fit_circle(x: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Least-squares circle through points: centre x, centre y, radius."""
    a = np.column_stack([x, y, np.ones_like(x)])
    d, e, f = np.linalg.lstsq(a, -(x * x + y * y), rcond=None)[0]
    cx, cy = -d / 2, -e / 2
    return cx, cy, float(np.sqrt(cx * cx + cy * cy - f))
