"""GUI tests: offscreen Qt, an embedded simulator paced faster than real time, the main window on it."""

from __future__ import annotations

import os
from pathlib import Path

os.environ["QT_QPA_PLATFORM"] = "offscreen"  # before any Qt import creates the application

import pytest

from vilma.bus.base import BoundedQueue
from vilma.bus.topics import topic

SPEED = 4.0
"""Embedded simulation speed in the tests (x real time)."""
WAIT_MS = 120_000
"""Longest wait for the simulated car [ms of wall time]: a busy machine, and a first run compiling for a minute."""


@pytest.fixture
def screenshots(tmp_path):
    """Where the GUI tests save their screenshots: a temporary folder, or the README's ``docs/`` when
    ``VILMA_SCREENSHOTS=docs`` asks to redo them (``VILMA_SCREENSHOTS=docs pytest tests/gui``)."""
    if os.environ.get("VILMA_SCREENSHOTS") == "docs":
        return Path(__file__).resolve().parents[2] / "docs"
    return tmp_path


@pytest.fixture
def embedded():
    """The default scenario embedded (simulator + driver on a local bus), not started."""
    from vilma.gui.backend import Embedded

    backend = Embedded(speed=SPEED)
    yield backend
    backend.close()


def shown_window(qtbot, backend, record_dir):
    """The main window on ``backend``, shown, its backend started and the driver heard from."""
    from vilma.gui.main_window import MainWindow

    w = MainWindow(backend, refresh_ms=100, record_dir=record_dir)
    qtbot.addWidget(w)
    w.show()
    backend.start()
    qtbot.waitUntil(lambda: w.bridge.connected and "driver/status" in w.bridge.latest, timeout=WAIT_MS)
    return w


@pytest.fixture
def window(qtbot, embedded, tmp_path):
    """The main window on the embedded simulator, shown and running; recordings go to ``tmp_path``."""
    w = shown_window(qtbot, embedded, tmp_path)
    yield w
    w.close()


@pytest.fixture
def commands(embedded):
    """Every actuator command published on the bus, in order."""
    q = BoundedQueue(embedded.bus, topic("cmd"), maxsize=10_000)
    yield q
    q.close()


def speed_of(window) -> float:
    """The car's planar speed from the latest velocity message [m/s]."""
    return window.bridge.latest["velocity"].speed
