"""How fast the simulator's frames come, in wall-clock time: MORSE's ``time statistics``."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable


class FrameTimes:
    """The wall-clock time between the simulator's frames, MORSE's ``time statistics`` in fixed-step mode.

    ``mean_time`` and ``variance_time`` are the mean [s] and sample variance [s^2] of the intervals (MORSE's
    ``Stats``: Welford; the variance is 0 before two intervals). ``diff_real_time`` is the simulated time minus
    the real time, both since the first frame after the start or the last reset (vilma's clock then starts
    again) [s]: positive when the simulation runs ahead of real time. Frames come from the simulator's thread,
    questions from the server's.

    Args:
        time_ns: sim time [ns].
        wall_ns: a monotonic wall clock [ns].
    """

    def __init__(self, time_ns: Callable[[], int], wall_ns: Callable[[], int] = time.monotonic_ns) -> None:
        self._time_ns, self._wall_ns = time_ns, wall_ns
        self._lock = threading.Lock()
        self._n, self._mean, self._m2 = 0, 0.0, 0.0
        self._last: tuple[int, int] | None = None  # (wall, sim) [ns] of the last frame
        self._origin: tuple[int, int] | None = None  # of the first frame since the start or the last reset

    def frame(self) -> None:
        """Note a frame, now."""
        wall, sim = self._wall_ns(), int(self._time_ns())
        with self._lock:
            if self._last is not None:
                dt = (wall - self._last[0]) / 1e9
                self._n += 1
                delta = dt - self._mean
                self._mean += delta / self._n
                self._m2 += delta * (dt - self._mean)
            if self._last is None or sim < self._last[1]:
                self._origin = (wall, sim)
            self._last = (wall, sim)

    def statistics(self) -> dict[str, float]:
        """``{"mean_time", "variance_time", "diff_real_time"}`` (see the class docstring)."""
        wall = self._wall_ns()
        with self._lock:
            diff = 0.0
            if self._last is not None and self._origin is not None:
                diff = ((self._last[1] - self._origin[1]) - (wall - self._origin[0])) / 1e9
            return {"mean_time": self._mean, "variance_time": self._m2 / (self._n - 1) if self._n > 1 else 0.0,
                    "diff_real_time": diff}
