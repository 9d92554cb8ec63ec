"""MORSE-compatible socket server: the service port and one datastream port per component.

Runs an asyncio loop in a daemon thread. The simulator calls :meth:`MorseServer.publish`
with its readings and :meth:`MorseServer.publish_captures` with its laser scans (any thread,
never blocks); actuator streams and the robot's services
call ``on_command`` (on the server thread). Topology and lines: ``reference/morse-protocol.md``;
component fields and units: :mod:`vilma.morse.components`.

Deviations from MORSE, all more tolerant: blank request lines are ignored; ``<id> cancel``
only reaches requests of the same connection; a service client that ends its sending side
(``shutdown(SHUT_WR)``) still gets every reply, those of ``time sleep`` and ``reset_objects`` too, and its
last line counts even without a final ``\\n`` (MORSE drops the connection at once); the server closes the
connection after the last reply. It cannot tell a ``close()`` from that, so a client that closes while its
``time sleep`` runs holds it until its time is up, as in MORSE; a connection reset (RST) ends it at once.
Actuator messages may leave fields out (they default to 0); ``time now`` counts from the start of the run
(MORSE's ``use_relative_time``); ``reset_objects`` answers once the simulator has put the car back (its
next frame) rather than at once, so that every reading served after its reply is of the reset car.

Limits: at most ``max_connections`` connections over all the ports at once (a connection beyond them gets
a ``FAILED`` line and is closed). Each holds at most a line of :data:`~vilma.morse.protocol.MAX_LINE`
bytes, one read of requests not yet answered (asyncio reads 256 KiB at most) and
:data:`SERVICE_HIGH_WATER` bytes of replies (or ``stream_buffer_limit`` of frames) plus one reply or
batch, which bounds the memory clients can make the server hold: about 100 MiB with the defaults.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import socket
import threading
import time
from collections import deque
from collections.abc import Callable, Collection, Iterable, Mapping
from typing import TYPE_CHECKING, Any

from vilma.core.messages import ActuatorCommand, Message
from vilma.core.net import is_loopback
from vilma.core.ratelimit import WarningThrottle
from vilma.morse import protocol as p
from vilma.morse.components import LASER_RANGE
from vilma.morse.core import MorseCore
from vilma.morse.ports import bind_ports
from vilma.vehicle.params import VehicleParams

if TYPE_CHECKING:
    from vilma.sensors import SensorSuite
    from vilma.sensors.base import Readings

log = logging.getLogger(__name__)

SERVICE_HIGH_WATER = 64 * 1024
"""Replies queued to one service client [bytes] above which the server answers no more of its requests (and
stops reading them) until it reads."""
MAX_CONNECTIONS = 256
"""Connections one server takes at once over all its ports. pymorse opens one to the service port and one a
datastream it reads, so this serves tens of clients, and keeps file descriptors and memory bounded."""
PUBLISH_BACKLOG = 256
"""Batches of readings or captures waiting for the server thread; older ones are dropped beyond it."""
TICK = 0.02
"""Period of the check for due ``time sleep`` requests when no readings arrive [s]."""


def _address(transport: asyncio.BaseTransport) -> str:
    """The peer's IP address, or ``?``."""
    peer = transport.get_extra_info("peername")
    return str(peer[0]) if peer else "?"


class _ServiceConn(asyncio.Protocol):
    """One client of the service port: its requests are answered in order, while it reads the replies."""

    def __init__(self, server: MorseServer) -> None:
        self.server, self.lines = server, p.LineBuffer()
        self.transport: asyncio.Transport | None = None
        self.address = "?"
        self._todo: deque[bytes | p.TooLong] = deque()
        """Request lines received and not answered yet (while the client does not read its replies)."""
        self._blocked = False
        self._eof = False

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.address = _address(transport)
        if self.server._admit(transport, self.address):
            self.transport = transport
            transport.set_write_buffer_limits(high=SERVICE_HIGH_WATER)
            self.server._service_conns.add(self)

    def data_received(self, data: bytes) -> None:
        self._todo.extend(self.lines.feed(data))
        self._answer()

    def eof_received(self) -> bool:
        """The client sends no more: its last line counts without a ``\\n``; the connection closes once every
        request is answered (True: asyncio keeps it open for the replies)."""
        self._eof = True
        self._todo.extend(self.lines.end())
        self._answer()
        return True

    def _answer(self) -> None:
        while self._todo and not self._blocked:
            if self.transport is None or self.transport.is_closing():
                return
            self.server.core.handle_line(self, self._todo.popleft())
        self._close_when_done()

    def _close_when_done(self) -> None:
        if self._eof and not self._todo and self.transport is not None and not self.server.core.waiting(self):
            self.transport.close()

    def connection_lost(self, exc: Exception | None) -> None:
        self.server._service_conns.discard(self)
        self.server.core.peer_gone(self)
        self.transport = None
        self._todo.clear()

    def pause_writing(self) -> None:  # the client does not read its replies: answer and read no more for now
        self._blocked = True
        if self.transport is not None:
            self.transport.pause_reading()

    def resume_writing(self) -> None:
        self._blocked = False
        if self.transport is not None:
            self.transport.resume_reading()
        self._answer()

    def send(self, data: bytes) -> None:
        """Queue reply bytes (dropped if the connection is closing); after the client's end, the last reply
        closes the connection."""
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(data)
            self._close_when_done()


class _OutConn(asyncio.Protocol):
    """One reader of a sensor datastream: gets every frame while it keeps up, loses frames otherwise."""

    def __init__(self, server: MorseServer, fqn: str) -> None:
        self.server, self.fqn = server, fqn
        self.transport: asyncio.Transport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        if not self.server._admit(transport, _address(transport)):
            return
        self.transport = transport
        sock = transport.get_extra_info("socket")
        if sock is not None:  # a small kernel buffer too: a slow reader gets fresh frames, not seconds-old ones
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.server.stream_buffer_limit)
        self.server._out[self.fqn].add(self)

    def data_received(self, data: bytes) -> None:
        pass  # MORSE ignores what clients write to an output stream

    def connection_lost(self, exc: Exception | None) -> None:
        self.server._out[self.fqn].discard(self)
        self.transport = None

    def write(self, data: bytes, lines: int) -> None:
        """Send ``lines`` frames, or drop them when this client already has too much queued."""
        t, st = self.transport, self.server._stats[self.fqn]
        if t is None or t.is_closing():
            return
        if t.get_write_buffer_size() > self.server.stream_buffer_limit:
            st["dropped"] += lines
            return
        t.write(data)  # goes straight to the socket when the kernel has room; else it is queued here
        st["sent"] += lines
        st["max_buffered"] = max(st["max_buffered"], t.get_write_buffer_size())


class _InConn(asyncio.Protocol):
    """One writer of an actuator datastream: each read applies its last complete line."""

    def __init__(self, server: MorseServer, fqn: str) -> None:
        self.server, self.fqn, self.lines = server, fqn, p.LineBuffer()
        self.transport: asyncio.Transport | None = None
        self.address = "?"
        self.errors = 0

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.address = _address(transport)
        if not self.server._admit(transport, self.address):
            return
        self.transport = transport
        self.server._in_conns.add(self)
        core = self.server.core
        if not core.access.allowed(self.address):
            msg = core.access.refusal(self.address)
            log.warning("%s stream: %s", self.fqn, msg)
            transport.write(p.format_reply("", p.FAILED, msg).lstrip())
            transport.close()

    def data_received(self, data: bytes) -> None:
        last = None
        for line in self.lines.feed(data):
            if isinstance(line, p.TooLong):
                self._error(f"{self.fqn}: line longer than {p.MAX_LINE} bytes skipped")
            elif line.strip():
                last = line
        if last is not None and self.transport is not None and not self.transport.is_closing():
            err = self.server.core.actuator_line(self.fqn, self.address, last)
            if err:
                self._error(err)

    def _error(self, msg: str) -> None:
        self.errors += 1
        log.log(logging.WARNING if self.errors == 1 else logging.DEBUG, "%s (from %s; ignored)", msg, self.address)

    def connection_lost(self, exc: Exception | None) -> None:
        self.server._in_conns.discard(self)
        self.transport = None


class MorseServer:
    """MORSE socket interface of one vilma car (robot ``robot``), for pymorse and raw-socket clients.

    Args:
        host: address to bind; anything but loopback is logged as a warning (commands then come from
            the network: see ``allow_commands_from``).
        service_port: first service port tried (the first free of ``service_port .. +9``); 0: any free.
        stream_port: first datastream port; components get consecutive free ports in
            :data:`~vilma.morse.components.COMPONENTS` order, then ``laser`` if there is one; 0: any free.
        robot: the robot's name; components are ``<robot>.pose`` ...
        on_command: gets every actuator command, on the server thread (queue it; keep it cheap).
        on_reset: called by ``simulation reset_objects`` with a function to call (any thread) once the car is
            back, before the simulator's next :meth:`publish` (``SimNode.reset`` does); the reply waits for it.
            None: that service answers FAILED.
        on_quit: called after ``simulation quit`` is answered and the sockets close (None: FAILED).
        time_ns: current sim time [ns] (``time now``, ``time sleep``, command stamps).
        allow_commands_from: addresses or networks whose commands (actuator streams, the robot's
            services, motion services, reset, quit, (de)activate) are taken; None: all.
        vehicle: the car, for MotionVW (wheelbase, limits); default the ``vilma`` preset.
        stream_buffer_limit: bytes queued to one datastream reader above which its frames are dropped.
        world_topics: the simulator's world sensor topics (``("camera/front", "laser")``...): with
            ``laser``, the robot has a ``laser`` component (MORSE's ``LaserScanner``) fed by
            :meth:`publish_captures`; cameras are not served.
        laser_range: the laser's reach [m]: the range of a ray without a hit (MORSE's, not inf).
        sensors: the car's sensors, for where the GPS and IMU sit (``get_configurations``,
            ``get_scene_objects``); default :class:`~vilma.sensors.SensorSuite`'s.
        wall_ns: a monotonic wall clock [ns], which times the frames for ``time statistics``.
        max_connections: connections taken at once over all the ports; one more gets a ``FAILED`` line and
            is closed.
    """

    def __init__(self, *, host: str = "127.0.0.1", service_port: int = 4000, stream_port: int = 60000,
                 robot: str = "vilma", on_command: Callable[[ActuatorCommand], None],
                 on_reset: Callable[[Callable[[], None]], None] | None = None,
                 on_quit: Callable[[], None] | None = None, time_ns: Callable[[], int],
                 allow_commands_from: Collection[str] | None = None, vehicle: VehicleParams | None = None,
                 stream_buffer_limit: int = 64 * 1024, world_topics: Collection[str] = (),
                 laser_range: float = LASER_RANGE, sensors: SensorSuite | None = None,
                 wall_ns: Callable[[], int] = time.monotonic_ns, max_connections: int = MAX_CONNECTIONS) -> None:
        for name, port in (("service_port", service_port), ("stream_port", stream_port)):
            if not 0 <= port <= 65535:
                raise ValueError(f"{name} must be in 0..65535 (0: any free port), got {port}")
        self.host, self._service_port, self._stream_port = host, service_port, stream_port
        self.stream_buffer_limit, self.max_connections = stream_buffer_limit, max_connections
        self.core = MorseCore(robot=robot, on_command=on_command, on_reset=on_reset, on_quit=on_quit,
                              time_ns=time_ns, allow_commands_from=allow_commands_from, vehicle=vehicle,
                              shutdown=self._close_sockets, world_topics=world_topics, laser_range=laser_range,
                              sensors=sensors, wall_ns=wall_ns)
        self.stream_ports: dict[str, int] = {}
        self._address: tuple[str, int] | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._servers: list[asyncio.base_events.Server] = []
        self._service_conns: set[_ServiceConn] = set()
        self._in_conns: set[_InConn] = set()
        self._out: dict[str, set[_OutConn]] = {f: set() for f, s in self.core.specs.items() if s.direction == "OUT"}
        self._stats = {f: {"sent": 0, "dropped": 0, "max_buffered": 0} for f in self._out}
        self._lock = threading.Lock()
        self._queue: deque[tuple[Callable[[Any, set[str]], dict[str, bytes]], Any, int]] = deque()
        self._scheduled = False
        self._open = False
        self.publish_dropped = 0
        """Batches of readings or captures dropped because the server thread fell behind."""
        self._warnings = WarningThrottle(log)  # a client opening connections in a loop gets a line a second

    # -- life cycle --------------------------------------------------------------------------------------

    @property
    def service_address(self) -> tuple[str, int]:
        """``(host, port)`` of the service port."""
        if self._address is None:
            raise RuntimeError("MorseServer is not started: call start() first")
        return self._address

    def start(self) -> None:
        """Bind every port and serve from a daemon thread; returns once listening.

        Raises:
            ~vilma.morse.ports.ListenError: no free service port in ``service_port .. +9``, no free stream
                port, or ``host`` is not an address of this machine.
        """
        if self._thread is not None:
            raise RuntimeError("MorseServer.start() was already called; make a new server to restart")
        socks = bind_ports(self.host, self._service_port, self._stream_port, self.core.specs)
        self._address = (self.host, socks[""].getsockname()[1])
        self.stream_ports.update((fqn, sock.getsockname()[1]) for fqn, sock in socks.items() if fqn)
        self.core.stream_ports = dict(self.stream_ports)
        if not is_loopback(self.host):
            log.warning("MORSE interface bound to %s, not loopback: anyone who can reach it can drive the car "
                        "(restrict with allow_commands_from)", self.host or "all interfaces")
        loop = asyncio.new_event_loop()
        self._loop = loop
        self._thread = threading.Thread(target=self._run, args=(loop,), name="vilma-morse", daemon=True)
        self._thread.start()
        try:
            asyncio.run_coroutine_threadsafe(self._serve(socks), loop).result(timeout=5.0)
        except BaseException:
            for s in socks.values():
                s.close()
            self.stop()
            raise
        log.info("MORSE interface: services on %s:%d, streams %s", *self.service_address,
                 ", ".join(f"{f} {p}" for f, p in self.stream_ports.items()))

    def __enter__(self) -> MorseServer:
        """Start it (:meth:`start`); it stops at the end of the ``with`` block, however that ends."""
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    async def _serve(self, socks: dict[str, socket.socket]) -> None:
        loop = asyncio.get_running_loop()
        for fqn, sock in socks.items():
            if not fqn:
                factory: Callable[[], asyncio.Protocol] = lambda: _ServiceConn(self)  # noqa: E731
            elif fqn in self._out:
                factory = lambda fqn=fqn: _OutConn(self, fqn)  # noqa: E731
            else:
                factory = lambda fqn=fqn: _InConn(self, fqn)  # noqa: E731
            self._servers.append(await loop.create_server(factory, sock=sock, backlog=128))
        self._open = True
        loop.call_later(TICK, self._tick)

    def _admit(self, transport: asyncio.Transport, address: str) -> bool:
        """Whether a new connection fits under ``max_connections``; if not, it gets a FAILED line and is closed."""
        taken = len(self._service_conns) + len(self._in_conns) + sum(len(c) for c in self._out.values())
        if taken < self.max_connections:
            return True
        msg = (f"vilma: this MORSE interface takes {self.max_connections} connections at once and has them all; "
               f"close one and retry")
        self._warnings.warning("full", "MORSE: refused a connection from %s: %d connections are open, the most "
                               "it takes", address, taken)
        transport.write(p.format_reply("", p.FAILED, msg).lstrip())
        transport.close()
        return False

    def _loop_error(self, loop: asyncio.AbstractEventLoop, context: dict[str, Any]) -> None:
        """asyncio's errors: one that cannot accept (out of file descriptors) is a warning a second at most."""
        exc = context.get("exception")
        if isinstance(exc, OSError) and context.get("message", "").startswith("socket.accept()"):
            self._warnings.warning("accept", "MORSE: cannot accept connections: %s (the process has too many "
                                   "open files); retrying", exc)
        elif isinstance(exc, ValueError) and not self._open:  # asyncio retrying such an accept on a port closed since
            log.debug("MORSE: %s", context.get("message"))
        else:
            loop.default_exception_handler(context)

    def _run(self, loop: asyncio.AbstractEventLoop) -> None:
        asyncio.set_event_loop(loop)
        loop.set_exception_handler(self._loop_error)
        try:
            loop.run_forever()
        finally:
            self._close_sockets(abort=True)
            loop.run_until_complete(asyncio.sleep(0))  # let the transports finish closing their sockets
            loop.close()

    def stop(self) -> None:
        """Close every socket (within 1 s) and end the server thread. Safe to call twice or from a callback."""
        loop, thread = self._loop, self._thread
        if loop is None or thread is None:
            return
        self._open = False
        if threading.current_thread() is thread:  # from on_quit or on_command: finish after this callback
            self._close_sockets(abort=True)
            loop.stop()
            return
        with contextlib.suppress(RuntimeError):  # the loop has already stopped
            loop.call_soon_threadsafe(self._close_sockets, True)
            loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=1.0)
        if thread.is_alive():
            log.warning("MORSE server thread did not stop within 1 s")

    def _close_sockets(self, abort: bool = False) -> None:
        """Stop listening and close every connection: at once (``abort``), or flushing replies first (quit)."""
        self._open = False
        for srv in self._servers:
            srv.close()
        self._servers.clear()
        conns: list[Any] = [*self._service_conns, *self._in_conns, *(c for s in self._out.values() for c in s)]
        for c in conns:
            t = c.transport
            if t is None:
                continue
            if abort or not isinstance(c, _ServiceConn):
                t.abort()
            else:
                t.close()  # deliver the quit reply, then close
        if not abort and self._loop is not None:
            self._loop.call_later(1.0, self._close_sockets, True)

    def _tick(self) -> None:
        if not self._open or self._loop is None:
            return
        try:
            self.core.check_pending()
        except Exception:
            log.exception("MORSE time sleep check failed")
        self._loop.call_later(TICK, self._tick)

    # -- data --------------------------------------------------------------------------------------------

    def publish(self, readings: dict[str, Readings]) -> None:
        """Stream a frame's readings (by vilma sensor name): one JSON line per reading on its component's
        datastream. Call it once a frame: that times the frames (``time statistics``). Thread-safe, never
        blocks; ignored before start and after stop."""
        if self._open:
            self.core.frames.frame()
        self._enqueue(self.core.readings, readings)

    def publish_captures(self, captures: Mapping[str, Message] | Iterable[tuple[str, Message]]) -> None:
        """Stream the world sensors' messages (topic name -> message, e.g. ``{"laser": PointCloud}``, or the
        (topic, message) pairs of ``Simulator.take_captures`` in time order): a JSON line each on the
        component's datastream (``laser``); topics without a component (cameras) are ignored, a malformed scan
        is dropped with a warning. Thread-safe, never blocks; ignored before start and after stop."""
        self._enqueue(self.core.captures, captures if isinstance(captures, Mapping) else list(captures))

    def _enqueue(self, lines: Callable[[Any, set[str]], dict[str, bytes]], batch: Any) -> None:
        """Queue ``batch`` for the server thread, which turns it into lines with ``lines(batch, wanted)``; the
        resets applied so far go with it (what was measured before one is stale: see ``MorseCore.catch_up``)."""
        loop = self._loop
        if loop is None or not self._open:
            return
        resets = self.core.resets_applied
        with self._lock:
            if len(self._queue) >= PUBLISH_BACKLOG:
                self._queue.popleft()
                self.publish_dropped += 1
            self._queue.append((lines, batch, resets))
            if self._scheduled:
                return
            self._scheduled = True
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile
            loop.call_soon_threadsafe(self._drain)

    def _drain(self) -> None:
        with self._lock:
            batches = list(self._queue)
            self._queue.clear()
            self._scheduled = False
        if not self._open:
            return
        wanted = {fqn for fqn, conns in self._out.items() if conns}
        for lines_of, batch, resets in batches:
            try:
                self.core.catch_up(resets)
                lines = lines_of(batch, wanted)
            except Exception:
                log.exception("MORSE: could not stream a batch of readings")
                continue
            for fqn, data in lines.items():
                n = data.count(b"\n")
                for conn in list(self._out[fqn]):
                    conn.write(data, n)

    def stats(self) -> dict[str, dict[str, int]]:
        """Per sensor stream: ``clients``, frames ``sent`` and ``dropped`` (slow readers), ``max_buffered``
        bytes queued to one reader, and ``buffered`` now (the largest over its readers). Call it from any
        thread; the numbers are a snapshot."""
        out = {}
        for fqn, conns in self._out.items():
            sizes = [c.transport.get_write_buffer_size() for c in list(conns) if c.transport is not None]
            out[fqn] = {"clients": len(conns), "buffered": max(sizes, default=0), **self._stats[fqn]}
        return out
