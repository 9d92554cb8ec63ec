"""Warnings about bad input at most once a second per cause, so that a peer flooding bad messages cannot flood
the log (the Zenoh bus, the ROS 1 bridge, the simulator's clamped commands)."""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable, Hashable


class WarningThrottle:
    """``log.warning`` at most once per ``period`` of ``clock`` [s] for each cause; the next warning logged of a
    cause says how many of it were held back since the last.

    A cause is a label from a small fixed set (a topic, a kind of fault), never text taken from the input, so
    the memory held stays bounded. Safe to call from any thread.
    """

    def __init__(self, log: logging.Logger, period: float = 1.0, clock: Callable[[], float] = time.monotonic) -> None:
        self.log, self.period, self._clock = log, period, clock
        self._lock = threading.Lock()
        self._causes: dict[Hashable, tuple[float, int]] = {}
        """By cause: when one was last logged [s] and how many were held back since."""

    def warning(self, cause: Hashable, msg: str, *args: object) -> None:
        """``log.warning(msg, *args)``, unless a warning of ``cause`` was logged less than ``period`` ago."""
        now = self._clock()
        with self._lock:
            last, held = self._causes.get(cause, (-math.inf, 0))
            if now - last < self.period:
                self._causes[cause] = (last, held + 1)
                return
            self._causes[cause] = (now, 0)
        if held:
            self.log.warning(f"{msg} (%d more like it in the last %.1f s not shown)", *args, held, now - last)
        else:
            self.log.warning(msg, *args)
