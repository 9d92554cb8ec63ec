"""The GUI's backends: the embedded simulator and driver, or a bus to them elsewhere."""

from __future__ import annotations

import math
import threading

import pytest

from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core.messages import SimControl
from vilma.gui.backend import Embedded, Remote


def test_an_embedded_backend_in_a_with_block_stops_and_leaves_its_bus_even_when_the_block_raises():
    with pytest.raises(RuntimeError, match="boom"), Embedded(speed=1.0) as backend:
        assert isinstance(backend, Embedded)
        backend.start()
        assert backend.running and backend.bus.request(topic("sim/cmd"), SimControl(action="status")).ok
        raise RuntimeError("boom")
    assert not backend.running
    reply = backend.bus.request(topic("sim/cmd"), SimControl(action="status"))
    assert reply.error == f"nobody answers on {topic('sim/cmd')}"


def test_a_remote_backend_in_a_with_block_closes_its_bus_even_when_the_block_raises():
    closed = []

    class Bus(LocalBus):
        def close(self) -> None:
            closed.append(self)
            super().close()

    with pytest.raises(RuntimeError, match="boom"), Remote(Bus()) as backend:
        assert isinstance(backend, Remote)
        raise RuntimeError("boom")
    assert closed == [backend.bus]


def test_the_embedded_simulator_drives_reactive_traffic_which_the_map_draws_and_the_guis_reset_restarts(
        qtbot, tmp_path):
    from tests.gui.conftest import SPEED, WAIT_MS, shown_window
    from tests.scenario.test_reactive_traffic import CAR_SPEED, CAR_X, _scenario

    sc = _scenario(tmp_path, "traffic: reactive")
    went_back, last = threading.Event(), [0]

    def status(msg) -> None:  # the sim clock going back: the reset was applied
        if msg.stamp_ns < last[0]:
            went_back.set()
        last[0] = msg.stamp_ns

    with Embedded(sc, speed=SPEED) as backend:
        sim, sub = backend.sim, backend.bus.subscribe(topic("sim/status"), status)
        traffic, r = sim.config.traffic, sim.config.reactive
        assert r is not None and traffic is r.traffic and traffic.ring  # open-ended: a ring
        w = shown_window(qtbot, backend, tmp_path)
        assert w.plots.road.view.traffic is traffic  # the map draws the traffic where the simulator drives it
        qtbot.waitUntil(lambda: sim.clock.time_s > 3.0, timeout=WAIT_MS)
        assert CAR_X < traffic.at(3.0)[0][0, 0] < CAR_X + CAR_SPEED * 3.0 - 1.0  # braking behind the ego
        w.reset_simulation()
        assert went_back.wait(WAIT_MS / 1000)
        # restarted with the clock: the traffic is filled to one period ahead of it (or is being so, on the
        # simulator's thread), not of the run before
        t0, j, t1 = sim.clock.time_s, int(r.arrays.j[0]), sim.clock.time_s
        assert math.floor(t0 / r.period + 1e-9) <= j <= math.floor(t1 / r.period + 1e-9) + 1
        sub.close()
        w.close()
