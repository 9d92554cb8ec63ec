"""A vilma simulator serving the MORSE interface on loopback, paced in a thread, and a raw line client."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from dataclasses import dataclass

import pytest

from vilma.bus.local import LocalBus
from vilma.bus.nodes import SimNode
from vilma.bus.paced import run_paced
from vilma.morse import MorseServer
from vilma.sensors import SensorSuite
from vilma.sensors.imu import ImuParams
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import VehicleState

SPEED = 4.0
"""The served simulator runs this many times faster than real time (MORSE's time services use sim time)."""
START = VehicleState(x=3.0, y=-2.0, yaw=0.5)
"""Where the car of the ``scene`` fixture starts."""
IMU_AT = (0.5, 0.2, 0.3)
"""Where its IMU is mounted, in the body frame from the centre of mass [m]."""


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


def serve(speed: float = SPEED, config: SimConfig | None = None, **kw) -> Served:
    """A paced simulator (of ``config``) with its MORSE server on free loopback ports (stop with ``.stop.set()``)."""
    sim = Simulator(config)
    node = SimNode(sim, LocalBus())
    stop = threading.Event()
    commands: list = []

    def on_command(cmd) -> None:
        commands.append(cmd)
        node.command(cmd)

    server = MorseServer(service_port=0, stream_port=0, on_command=on_command, on_reset=node.reset,
                         on_quit=stop.set, time_ns=lambda: sim.time_ns, sensors=sim.config.sensors, **kw)
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


@pytest.fixture
def scene() -> Iterator[Served]:
    """The served simulator with its car starting at :data:`START` and its IMU at :data:`IMU_AT`."""
    s = serve(config=SimConfig(initial=START, sensors=SensorSuite(imu=ImuParams(offset=IMU_AT))))
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

    def skip_received(self) -> None:
        """Drop every complete line received so far (what was sent before now); the next ``line()`` comes later."""
        self.sock.setblocking(False)
        try:
            while chunk := self.sock.recv(65536):
                self.buf += chunk
        except BlockingIOError:
            pass
        finally:
            self.sock.settimeout(10.0)
        self.buf = self.buf[self.buf.rfind(b"\n") + 1:]

    def close(self) -> None:
        self.sock.close()


@pytest.fixture
def client(served: Served) -> Iterator[LineClient]:
    c = LineClient(served.port)
    yield c
    c.close()
