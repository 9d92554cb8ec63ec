"""``vilma replay RUN.mcap``: a recording played back onto the bus, as if live, with pause, seek and speed.

:class:`Replayer` publishes every bus topic of the recording (sensors,
``cmd``, ``driver/status``, ``sim/status``, camera images and laser scans) in stamp order from its own
thread, paced so that ``speed`` seconds of sim time pass per wall second.
The topics written beside a sensor's (``tf``, ``pose/euler``...) and ``drive_log`` are not bus topics
and are not played. The whole recording is held in memory (about 150 bytes a message;
camera images and laser scans as recorded, decoded as they are played).
"""

from __future__ import annotations

import bisect
import functools
import logging
import threading
import time
from collections.abc import Callable
from pathlib import Path

from vilma.bus.base import Bus
from vilma.bus.topics import TOPICS, topic
from vilma.core.messages import Message
from vilma.record.reader import Recording, read_recording
from vilma.record.world_cdr import decode_world

log = logging.getLogger(__name__)

PLAYED = tuple(n for n in TOPICS if n not in ("driver/cmd", "sim/cmd"))
"""Topics a replay publishes."""


class Replayer:
    """Plays ``recording`` onto ``bus`` under car ``car`` (the recorded car's name by default).

    Use :meth:`start`, then :meth:`pause` / :meth:`resume`, :meth:`seek`, :meth:`set_speed`; :meth:`wait`
    until it has played to the end; :meth:`close`.
    """

    def __init__(self, recording: Recording | Path, bus: Bus, speed: float = 1.0, car: str | None = None) -> None:
        rec = recording if isinstance(recording, Recording) else read_recording(recording)
        self.bus, self.car = bus, car or rec.car
        items: list[tuple[int, int, str, Message | Callable[[], Message]]] = []
        for order, name in enumerate(PLAYED):
            if rec.count(name):
                key = topic(name, self.car)
                items += [(msg.stamp_ns, order, key, msg) for msg in rec.messages(name)]
        for order, name in enumerate(rec.world_topics, len(PLAYED)):
            key, (stamps, payloads) = topic(name, self.car), rec.world_payloads(name)
            items += [(t, order, key, functools.partial(decode_world, rec.schemas[name], *p))
                      for t, p in zip(stamps, payloads, strict=True)]
        items.sort(key=lambda it: (it[0], it[1]))
        self._items = [(t, key, msg) for t, _, key, msg in items]
        self._stamps = [t for t, _, _ in self._items]
        self.start_ns = self._stamps[0] if self._stamps else 0
        self.end_ns = self._stamps[-1] if self._stamps else 0
        self._check_speed(speed)
        self._speed = speed
        self._i = 0
        self._paused = False
        self._stop = False
        self._cv = threading.Condition()
        self._anchor = (time.monotonic(), self.start_ns)  # (wall [s], sim [ns]) that correspond
        self._done = threading.Event()
        self._parked = threading.Event()
        self._thread = threading.Thread(target=self._play, name="vilma-replay", daemon=True)
        self.published = 0
        """Messages published so far."""

    @staticmethod
    def _check_speed(speed: float) -> None:
        if not 0 < speed < float("inf"):
            raise ValueError(f"replay speed must be a positive factor, got {speed:g}")

    @property
    def position_ns(self) -> int:
        """Sim time of the next message to play [ns] (the end once finished)."""
        with self._cv:
            return self._stamps[self._i] if self._i < len(self._stamps) else self.end_ns

    @property
    def paused(self) -> bool:
        return self._paused

    def start(self) -> Replayer:
        """Start playing (from the current position)."""
        with self._cv:
            self._anchor = (time.monotonic(), self.position_ns if self._i < len(self._stamps) else self.end_ns)
        self._thread.start()
        return self

    def pause(self, timeout: float = 2.0) -> None:
        """Stop publishing; returns once the player is parked (nothing more is published until :meth:`resume`)."""
        with self._cv:
            self._paused = True
            self._parked.clear()
            self._cv.notify_all()
        if self._thread.is_alive() and not self._done.is_set():
            self._parked.wait(timeout)

    def resume(self) -> None:
        """Go on from where it stands."""
        with self._cv:
            self._paused = False
            self._reanchor()
            self._cv.notify_all()

    def seek(self, t_s: float) -> None:
        """Jump to sim time ``t_s`` [s] (the first message at or after it plays next).

        Raises:
            ValueError: ``t_s`` is not within 0 and the last message's time.
        """
        if not 0 <= t_s <= self.end_ns * 1e-9:
            raise ValueError(f"{t_s:g} s is not within the recording's sim time, 0 to {self.end_ns * 1e-9:.2f} s")
        with self._cv:
            self._i = bisect.bisect_left(self._stamps, round(t_s * 1e9))
            self._done.clear()
            self._reanchor()
            self._cv.notify_all()

    def set_speed(self, speed: float) -> None:
        """Play ``speed`` sim seconds per wall second from now on."""
        self._check_speed(speed)
        with self._cv:
            self._speed = speed
            self._reanchor()
            self._cv.notify_all()

    def _reanchor(self) -> None:
        nxt = self._stamps[self._i] if self._i < len(self._stamps) else self.end_ns
        self._anchor = (time.monotonic(), nxt)

    def wait(self, timeout: float | None = None) -> bool:
        """Wait until everything was played; True if it was."""
        return self._done.wait(timeout)

    def close(self) -> None:
        """Stop the player thread."""
        with self._cv:
            self._stop = True
            self._cv.notify_all()
        if self._thread.is_alive():
            self._thread.join(2.0)

    def _play(self) -> None:
        while True:
            with self._cv:
                while not self._stop and (self._paused or self._i >= len(self._items)):
                    if self._i >= len(self._items):
                        self._done.set()
                    if self._paused:
                        self._parked.set()
                    self._cv.wait()
                if self._stop:
                    self._parked.set()
                    return
                t, key, msg = self._items[self._i]
                wall0, sim0 = self._anchor
                due = wall0 + (t - sim0) * 1e-9 / self._speed
                left = due - time.monotonic()
                if left > 0:
                    self._cv.wait(min(left, 0.1))  # pause, seek or speed may change meanwhile
                    continue
                self._i += 1
            if not isinstance(msg, Message):
                try:
                    msg = msg()
                except ValueError as e:
                    log.warning("replay: %s at %.3f s; skipped", e, t * 1e-9)
                    continue
            self.bus.publish(key, msg)
            self.published += 1
