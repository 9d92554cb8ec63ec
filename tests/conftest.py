"""Shared test helpers."""

from __future__ import annotations

import atexit
import logging
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile

import numpy as np
import pytest

from vilma.core.messages import ActuatorCommand
from vilma.sensors import SensorSuite
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import NZ

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    # A suite started as a background job (`pytest &`, nohup) has SIGINT ignored, and the programs the tests start
    # would inherit that and ignore the Ctrl-C the tests send them: the tests' own processes take it again.
    signal.signal(signal.SIGINT, signal.default_int_handler)

os.environ["VILMA_SERVE"] = "off"  # the `vilma` commands tests start run in their own processes, not on a server
# what vilma keeps made once (course splines) in a folder of this session's, never the user's cache
os.environ["VILMA_CACHE_DIR"] = tempfile.mkdtemp(prefix="vilma-test-cache-")
atexit.register(shutil.rmtree, os.environ["VILMA_CACHE_DIR"], ignore_errors=True)


@pytest.fixture
def full_disk(monkeypatch):
    """Atomic writes fail as on a full disk, at the rename (:mod:`vilma.core.files`)."""
    from vilma.core import files

    def full(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(files.os, "replace", full)


STEP = SimConfig().step
"""The default physics step [s]."""

VILMA = (sys.executable, "-m", "vilma.app.cli")
"""The command that runs ``vilma`` in a child process."""


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now, for a child process that must be told its port before it starts."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Processes:
    """The processes a test starts; at the end of a ``with`` block or of the ``processes`` fixture, whichever still
    runs is killed and reaped."""

    def __init__(self) -> None:
        self.started: list[subprocess.Popen] = []

    def start(self, *argv: str, **kw) -> subprocess.Popen:
        """``Popen(argv, **kw)``; by default its stdout and stderr are one text pipe."""
        self.started.append(subprocess.Popen(argv, **{"stdout": subprocess.PIPE, "stderr": subprocess.STDOUT,
                                                       "text": True, **kw}))
        return self.started[-1]

    def vilma(self, *args: str, **kw) -> subprocess.Popen:
        """``vilma args`` started as :meth:`start` does."""
        return self.start(*VILMA, *args, **kw)

    def __enter__(self) -> Processes:
        return self

    def __exit__(self, *_) -> None:
        for p in self.started:
            if p.poll() is None:
                p.kill()
        for p in self.started:
            p.communicate(timeout=60)  # reaped, its pipes closed


@pytest.fixture
def processes():
    """A :class:`Processes`: every process the test starts through it is ended, whatever the test did."""
    with Processes() as started:
        yield started


@pytest.fixture(autouse=True)
def root_log_level():
    """Each test starts at the root logger's level pytest set: ``vilma.app.cli.main`` sets it for its process (-q, -v),
    which in a test run is every later test's."""
    root = logging.getLogger()
    level = root.level
    yield
    root.setLevel(level)


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
