"""The GUI's backends: the embedded simulator and driver, or a bus to them elsewhere."""

from __future__ import annotations

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
