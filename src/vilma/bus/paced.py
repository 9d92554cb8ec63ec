"""The simulator node advanced frame by frame at K times real time, publishing each frame on the bus."""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from collections.abc import Callable

from vilma.bus.nodes import SimNode
from vilma.sim import Pacer, Simulator

FRAME = 0.02
"""Sim time the simulator advances between publications [s] (the pose and velocity sensors' default period)."""
RATE_WINDOW = 1.0
"""Wall time over which the real-time factor is measured [s]."""


class RateMeter:
    """The real-time factor of frames of ``period`` [s] of sim time: sim seconds per wall second over the last
    ``window`` [s] of wall time, counted in frames (a reset, sim time back to 0, does not skew it)."""

    def __init__(self, period: float, now: float, window: float = RATE_WINDOW) -> None:
        self.period, self.window = period, window
        self._walls = deque([now])  # when the run began, and when each frame of the window ended [s]

    def frame(self, now: float) -> float:
        """A frame ended at wall time ``now`` [s]: the factor (NaN before any wall time passed)."""
        walls = self._walls
        walls.append(now)
        while now - walls[1] > self.window:  # (at least the last frame is kept)
            walls.popleft()
        return (len(walls) - 1) * self.period / (now - walls[0]) if now > walls[0] else math.nan


def run_paced(sim: Simulator, node: SimNode, speed: float, duration: float, stop: threading.Event,
              every: Callable[[], None] | None = None) -> None:
    """Advance ``sim`` frame by frame at ``speed`` x real time for ``duration`` [s] (inf: until ``stop``), the node's
    ``real_time_factor`` measured over the last second (:class:`RateMeter`)."""
    pacer = Pacer(sim, speed=speed, period=FRAME)
    meter = RateMeter(pacer.period, time.monotonic())

    def frame(readings) -> None:
        node.real_time_factor = meter.frame(time.monotonic())
        node.frame(readings, frame_ns)

    frame_ns = round(pacer.period * 1e9)
    left = duration
    while left > 0 and not stop.is_set():
        chunk = min(left, 1.0)
        pacer.run(chunk, on_period=frame, should_stop=stop.is_set, before_period=node.apply_pending)
        left -= chunk
        if every is not None:
            every()
