"""The in-process bus: publish calls the subscribers directly, no serialization."""

from __future__ import annotations

import logging
import threading

from vilma.bus.base import Handler, Server
from vilma.core.closing import Closeable
from vilma.core.messages import Message, Reply

log = logging.getLogger(__name__)


class _Sub:
    def __init__(self, table: dict[str, list], key: str, item, lock: threading.Lock) -> None:
        self._table, self._key, self._item, self._lock = table, key, item, lock

    def close(self) -> None:
        with self._lock:
            items = self._table.get(self._key, [])
            if self._item in items:
                items.remove(self._item)


class LocalBus(Closeable):
    """A :class:`~vilma.bus.base.Bus` inside one process. Subscribers run in the publisher's thread;
    one that raises is logged and the others still get the message."""

    def __init__(self) -> None:
        self._subs: dict[str, list[Handler]] = {}
        self._servers: dict[str, list[Server]] = {}
        self._lock = threading.Lock()

    def publish(self, key: str, msg: Message) -> None:
        with self._lock:
            handlers = list(self._subs.get(key, ()))
        for h in handlers:
            try:
                h(msg)
            except Exception:
                log.exception("subscriber of %s failed on %s", key, type(msg).__name__)

    def subscribe(self, key: str, handler: Handler) -> _Sub:
        with self._lock:
            self._subs.setdefault(key, []).append(handler)
        return _Sub(self._subs, key, handler, self._lock)

    def serve(self, key: str, server: Server) -> _Sub:
        with self._lock:
            self._servers.setdefault(key, []).append(server)
        return _Sub(self._servers, key, server, self._lock)

    def request(self, key: str, msg: Message, timeout: float = 2.0) -> Reply:
        with self._lock:
            servers = list(self._servers.get(key, ()))
        if not servers:
            return Reply(ok=False, error=f"nobody answers on {key}")
        try:
            return servers[0](msg)
        except Exception as e:
            log.exception("server of %s failed", key)
            return Reply(ok=False, error=f"{key}: {e}")

    def close(self) -> None:
        """Drop every subscriber and server (closing again does nothing)."""
        with self._lock:
            self._subs.clear()
            self._servers.clear()
