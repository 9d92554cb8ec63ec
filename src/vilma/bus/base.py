"""What every bus offers: publish, subscribe (callback, latest value, bounded queue), request-reply."""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable
from typing import Protocol, Self

from vilma.core.closing import Closeable
from vilma.core.messages import Message, Reply

Handler = Callable[[Message], None]
Server = Callable[[Message], Reply]


class Subscription(Protocol):
    """A subscription; :meth:`close` ends it."""

    def close(self) -> None: ...


class Bus(Protocol):
    """Typed messages between the parts of vilma, in one process or across hosts.

    Keys are full topic keys (:func:`vilma.bus.topics.topic`). Callbacks run on the bus's thread
    (the publisher's, for the local bus): keep them short, hand work over with :class:`Latest` or
    :class:`BoundedQueue`.
    """

    def publish(self, key: str, msg: Message) -> None:
        """Send ``msg`` to every subscriber of ``key``."""

    def subscribe(self, key: str, handler: Handler) -> Subscription:
        """Call ``handler(msg)`` for each message on ``key``."""

    def serve(self, key: str, server: Server) -> Subscription:
        """Answer requests on ``key`` with ``server(request) -> Reply``."""

    def request(self, key: str, msg: Message, timeout: float = 2.0) -> Reply:
        """Send a request and wait for its reply; a :class:`Reply` with ``ok`` False if none came."""

    def close(self) -> None:
        """End every subscription and release the bus; closing again does nothing."""

    def __enter__(self) -> Self:
        """The bus, closed at the end of the ``with`` block."""

    def __exit__(self, *exc: object) -> None: ...


class Latest(Closeable):
    """The latest message of a topic (older ones are overwritten): for a display that samples."""

    def __init__(self, bus: Bus, key: str) -> None:
        self.value: Message | None = None
        self.count = 0
        self._sub = bus.subscribe(key, self._take)

    def _take(self, msg: Message) -> None:
        self.value = msg
        self.count += 1

    def close(self) -> None:
        """Unsubscribe (closing again does nothing)."""
        self._sub.close()


class BoundedQueue(Closeable):
    """Messages of a topic kept in order, at most ``maxsize``; when full the oldest is dropped and counted."""

    def __init__(self, bus: Bus, key: str, maxsize: int = 1000) -> None:
        if maxsize < 1:
            raise ValueError(f"queue size must be >= 1, got {maxsize}")
        self._items: collections.deque[Message] = collections.deque(maxlen=maxsize)
        self._lock = threading.Lock()
        self._ready = threading.Condition(self._lock)
        self.dropped = 0
        self._sub = bus.subscribe(key, self._take)

    def _take(self, msg: Message) -> None:
        with self._ready:
            if len(self._items) == self._items.maxlen:
                self.dropped += 1
            self._items.append(msg)
            self._ready.notify_all()

    def drain(self) -> list[Message]:
        """Every message queued so far, oldest first; the queue is left empty."""
        with self._lock:
            out = list(self._items)
            self._items.clear()
        return out

    def wait(self, predicate: Callable[[Message], bool], timeout: float) -> Message | None:
        """Wait until a queued message satisfies ``predicate`` (it and those before it are consumed)."""
        deadline = time.monotonic() + timeout
        with self._ready:
            while True:
                while self._items:
                    msg = self._items.popleft()
                    if predicate(msg):
                        return msg
                left = deadline - time.monotonic()
                if left <= 0 or not self._ready.wait(left):
                    return None

    def close(self) -> None:
        """Unsubscribe (closing again does nothing)."""
        self._sub.close()
