"""The simulator node advanced frame by frame at K times real time, publishing each frame on the bus."""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

from vilma.bus.nodes import SimNode
from vilma.sim import Pacer, Simulator

FRAME = 0.02
"""Sim time the simulator advances between publications [s] (the pose and velocity sensors' default period)."""


def run_paced(sim: Simulator, node: SimNode, speed: float, duration: float, stop: threading.Event,
              every: Callable[[], None] | None = None) -> None:
    """Advance ``sim`` frame by frame at ``speed`` x real time for ``duration`` [s] (inf: until ``stop``)."""
    wall0, sim0 = time.monotonic(), sim.clock.time_s
    pacer = Pacer(sim, speed=speed, period=FRAME)

    def frame(readings) -> None:
        wall = time.monotonic() - wall0
        node.real_time_factor = (sim.clock.time_s - sim0) / wall if wall > 0 else math.nan
        node.frame(readings, frame_ns)

    frame_ns = round(pacer.period * 1e9)
    left = duration
    while left > 0 and not stop.is_set():
        chunk = min(left, 1.0)
        pacer.run(chunk, on_period=frame, should_stop=stop.is_set, before_period=node.apply_pending)
        left -= chunk
        if every is not None:
            every()
