"""The bus between processes and hosts: Zenoh 1.x, peer to peer, configured explicitly.

Out of the box Zenoh listens on every interface and scouts by multicast; vilma
does neither unless told: it listens and connects only on the endpoints given
(default: loopback), and multicast scouting is off. Commands and orders are
sent reliably with congestion control that blocks; sensor feeds (images and
scans too) may drop under congestion (a display wants the latest value, not a
backlog). Every message goes on one priority, so a frame's readings stay ahead
of its ``sim/status``, and none is express: Zenoh batches only what is already
queued (no wait for a batch to fill), so latency is that of express (p50 0.54
ms at 100 Hz on loopback) while a flood goes four times faster than one write
per message (220 000 against 54 000 messages/s). Zenoh stops reassembling a message once it outgrows the
largest frame (with its key and headers) and drops it, so no peer can make another hold more.
"""

from __future__ import annotations

import json
import logging
import re
import threading
import time
from dataclasses import dataclass

import zenoh

from vilma.bus.codec import MAX_WORLD_FRAME_BYTES, DecodeError, decode, encode
from vilma.bus.topics import SENSOR_TOPICS, WORLD_TOPICS, message_type
from vilma.core.closing import Closeable
from vilma.core.messages import Message, Reply
from vilma.core.net import check_endpoint, is_loopback
from vilma.core.ratelimit import WarningThrottle

log = logging.getLogger(__name__)

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
"""Where ``vilma sim`` listens and the other programs connect by default."""
MAX_MESSAGE_BYTES = MAX_WORLD_FRAME_BYTES + 2**20
"""The largest Zenoh message taken [bytes]: the largest frame, with room for its key and Zenoh's headers."""
_RUST_PLACE = re.compile(r" at /\S+\.rs:\d+\.?")
"""Where in Zenoh's Rust source an error was raised: no help to a user."""
LOOPBACK_ANY_PORT = "tcp/127.0.0.1:0"
"""Where the other programs listen by default: peers that meet through the simulator learn of each other
(gossip) and connect directly, so a driver's status reaches a GUI without passing through the simulator."""


@dataclass(frozen=True, slots=True, kw_only=True)
class ZenohConfig:
    """Endpoints of a Zenoh peer, as ``tcp/<address>:<port>`` (also ``udp/``, ``tls/``...), checked when made
    (:func:`~vilma.core.net.check_endpoint`)."""

    listen: tuple[str, ...] = ()
    """Endpoints to listen on (none: only connect out)."""
    connect: tuple[str, ...] = ()
    """Endpoints of peers to connect to."""
    multicast_scouting: bool = False
    """Find peers by UDP multicast on the local network (off: only the endpoints given)."""
    extra: tuple[tuple[str, str], ...] = ()
    """Other Zenoh settings: (key path, JSON5 value) pairs, e.g. ``("transport/unicast/max_links", "2")``."""

    def __post_init__(self) -> None:
        for field, listen in (("listen", True), ("connect", False)):
            for i, endpoint in enumerate(getattr(self, field)):
                try:
                    check_endpoint(endpoint, listen)
                except ValueError as e:
                    raise ValueError(f"{field} endpoint {i + 1}: {e}") from None

    def exposed(self) -> list[str]:
        """Listen endpoints that are not on the loopback interface."""
        return [e for e in self.listen if not is_loopback(e.split("/", 1)[-1].rsplit(":", 1)[0])]

    def to_zenoh(self) -> zenoh.Config:
        """The Zenoh configuration."""
        cfg = zenoh.Config()
        cfg.insert_json5("mode", '"peer"')
        cfg.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        cfg.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        cfg.insert_json5("scouting/multicast/enabled", json.dumps(self.multicast_scouting))
        cfg.insert_json5("transport/link/rx/max_message_size", str(MAX_MESSAGE_BYTES))
        for key, value in self.extra:
            cfg.insert_json5(key, value)
        return cfg


class ZenohBus(Closeable):
    """A :class:`~vilma.bus.base.Bus` over a Zenoh session. Callbacks run on Zenoh's threads."""

    def __init__(self, config: ZenohConfig) -> None:
        for e in config.exposed():
            log.warning("Zenoh listens on %s, beyond this machine: anyone who reaches it can drive the car", e)
        try:
            self.session = zenoh.open(config.to_zenoh())
        except zenoh.ZError as e:
            raise OSError(f"cannot open Zenoh on listen {list(config.listen)} connect {list(config.connect)}: "
                          f"{_RUST_PLACE.sub('', str(e))}") from None
        self.config = config
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._entities: list = []
        self._lock = threading.RLock()  # re-entrant: a local subscriber may publish from inside a put
        self._closed = False
        self._warnings = WarningThrottle(log)  # a peer flooding bad frames gets a line a second per topic

    def publish(self, key: str, msg: Message) -> None:
        """Send ``msg`` on ``key``; after :meth:`close` (a callback still running at shutdown) it is dropped."""
        frame = encode(msg)
        with self._lock:  # a publisher is not used by two threads at once, nor after close
            if self._closed:
                log.debug("bus closed: dropped a message on %s", key)
                return
            pub = self._publishers.get(key)
            if pub is None:
                sensor = key.rsplit("/", 1)[-1] in SENSOR_TOPICS or message_type(key) in WORLD_TOPICS.values()
                pub = self.session.declare_publisher(
                    key, reliability=zenoh.Reliability.RELIABLE,
                    congestion_control=zenoh.CongestionControl.DROP if sensor else zenoh.CongestionControl.BLOCK)
                self._publishers[key] = pub
            pub.put(frame)

    def subscribe(self, key: str, handler) -> _Undeclare:
        expected = message_type(key)

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                msg = decode(sample.payload.to_bytes(), expected)
            except DecodeError as e:
                self._warnings.warning(key, "dropped a message on %s: %s", key, e)
                return
            try:
                handler(msg)
            except Exception:
                log.exception("subscriber of %s failed", key)

        sub = self.session.declare_subscriber(key, on_sample)
        self._entities.append(sub)
        return _Undeclare(sub)

    def serve(self, key: str, server) -> _Undeclare:
        expected = message_type(key)

        def on_query(query: zenoh.Query) -> None:
            try:
                reply = server(decode(query.payload.to_bytes() if query.payload else b"", expected))
            except DecodeError as e:
                reply = Reply(ok=False, error=f"{key}: {e}")
            except Exception as e:
                log.exception("server of %s failed", key)
                reply = Reply(ok=False, error=f"{key}: {e}")
            query.reply(key, encode(reply))

        q = self.session.declare_queryable(key, on_query)
        self._entities.append(q)
        return _Undeclare(q)

    def request(self, key: str, msg: Message, timeout: float = 2.0) -> Reply:
        """Send a request and wait for its reply (see :class:`~vilma.bus.base.Bus`); within ``timeout`` [s], first
        for a server of ``key`` to be known: a peer just met tells of its servers a moment after it connects, and a
        query sent before that reaches nobody."""
        start = time.monotonic()
        if self._server_known(key, timeout) and (left := timeout - (time.monotonic() - start)) > 0:
            for r in self.session.get(key, payload=encode(msg), timeout=left):
                if r.ok is not None:
                    try:
                        out = decode(r.ok.payload.to_bytes(), Reply)
                    except DecodeError as e:
                        return Reply(ok=False, error=f"{key}: bad reply: {e}")
                    return out
            if time.monotonic() - start < timeout:  # (Zenoh's timer never ends early: the server ended the query)
                return Reply(ok=False, error=f"the server of {key} ended the request without an answer")
        return Reply(ok=False, error=f"nobody answered on {key} within {timeout:g} s (is the program running?)")

    def _server_known(self, key: str, timeout: float) -> bool:
        """Whether a server of ``key`` is known to this session, waiting up to ``timeout`` [s] for one."""
        known = threading.Event()
        with self.session.declare_querier(key) as querier, \
                querier.declare_matching_listener(lambda status: status.matching and known.set()):
            return querier.matching_status.matching or known.wait(timeout)

    def close(self) -> None:
        """Undeclare the publishers and close the session (closing again does nothing)."""
        with self._lock:
            self._closed = True
            for p in self._publishers.values():
                p.undeclare()
            self._publishers.clear()
        self.session.close()


class _Undeclare:
    def __init__(self, entity) -> None:
        self._entity = entity

    def close(self) -> None:
        """Undeclare (once: closing again does nothing)."""
        entity, self._entity = self._entity, None
        if entity is not None:
            entity.undeclare()
