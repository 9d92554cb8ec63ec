"""A vilma simulator serving the MORSE interface on loopback, paced in a thread, and a raw line client."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from dataclasses import dataclass

import pytest

from vilma.bus.local import LocalBus
from vilma.bus.nodes import SimNode
from vilma.morse import MorseServer
from vilma.programs import run_paced
from vilma.sim import Simulator

SPEED = 4.0
"""The served simulator runs this many times faster than real time (MORSE's time services use sim time)."""


@dataclass
class Served:
    sim: Simulator
    node: SimNode
    server: MorseServer
    stop: threading.Event
    commands: list

    @property
    def port(self) -> int:
        return self.server.service_address[1]


def serve(speed: float = SPEED, **kw) -> Served:
    """A paced simulator with its MORSE server on free loopback ports (stop with ``.stop.set()``)."""
    sim = Simulator()
    node = SimNode(sim, LocalBus())
    stop = threading.Event()
    commands: list = []

    def on_command(cmd) -> None:
        commands.append(cmd)
        node.command(cmd)

    server = MorseServer(service_port=0, stream_port=0, on_command=on_command, on_reset=node.reset,
                         on_quit=stop.set, time_ns=lambda: sim.time_ns, **kw)
    server.start()
    node.on_frame = server.publish
    threading.Thread(target=run_paced, args=(sim, node, speed, float("inf"), stop), daemon=True).start()
    return Served(sim, node, server, stop, commands)


@pytest.fixture
def served() -> Iterator[Served]:
    s = serve()
    yield s
    s.stop.set()
    s.server.stop()


class LineClient:
    """A raw TCP client reading ``\\n``-terminated lines as bytes (the ``\\n`` kept)."""

    def __init__(self, port: int, timeout: float = 10.0) -> None:
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        self.buf = b""

    def send(self, data: bytes) -> None:
        self.sock.sendall(data)

    def line(self) -> bytes:
        while b"\n" not in self.buf:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError(f"closed by the server; got {self.buf!r}")
            self.buf += chunk
        line, self.buf = self.buf.split(b"\n", 1)
        return line + b"\n"

    def ask(self, request: bytes) -> bytes:
        self.send(request)
        return self.line()

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def client(served: Served) -> Iterator[LineClient]:
    c = LineClient(served.port)
    yield c
    c.close()
