"""Pacing a simulator to real time (or k times real time), a layer over the lockstep simulator.

The simulator never reads the wall clock; this layer does. It advances the
simulator one period at a time and sleeps until the wall clock catches up
with ``sim time / speed``. When it falls behind by more than ``max_lag`` it
does not race to catch up: it re-anchors and counts the slip.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from vilma.sensors import Readings
from vilma.sim.simulator import Simulator


@dataclass(slots=True)
class PaceStats:
    """What pacing achieved so far."""

    periods: int = 0
    """Periods run."""
    late: int = 0
    """Periods that ended after their wall-clock deadline."""
    slips: int = 0
    """Times the pacer fell more than ``max_lag`` behind and re-anchored."""
    sim_seconds: float = 0.0
    wall_seconds: float = 0.0

    @property
    def real_time_factor(self) -> float:
        """Sim seconds per wall second."""
        return self.sim_seconds / self.wall_seconds if self.wall_seconds > 0 else float("nan")

    @property
    def on_time(self) -> float:
        """Share of periods that met their deadline."""
        return 1.0 - self.late / self.periods if self.periods else float("nan")


class Pacer:
    """Runs ``sim`` at ``speed`` times real time in steps of ``period`` sim seconds.

    Args:
        sim: the simulator to advance.
        speed: wall-clock speed-up, > 0 (1 = real time).
        period: sim seconds per advance (a whole number of physics steps).
        max_lag: wall seconds behind schedule before re-anchoring.
        clock: wall clock [s] (injectable for tests).
        sleep: sleep function [s] (injectable for tests).
    """

    def __init__(self, sim: Simulator, speed: float = 1.0, period: float = 0.02, max_lag: float = 0.25,
                 clock: Callable[[], float] = time.monotonic, sleep: Callable[[float], None] = time.sleep) -> None:
        if not speed > 0 or speed == float("inf"):
            raise ValueError(f"pacing speed must be a positive finite factor, got {speed!r}")
        self.sim, self.speed, self.max_lag = sim, speed, max_lag
        self.ticks = sim.clock.ticks_for(period)
        if self.ticks < 1:
            raise ValueError(f"pacing period {period!r} s is shorter than the physics step {sim.clock.step_s} s")
        self.period = self.ticks * sim.clock.step_s
        self.clock, self.sleep = clock, sleep
        self.stats = PaceStats()

    def run(self, seconds: float, on_period: Callable[[dict[str, Readings]], None] | None = None,
            should_stop: Callable[[], bool] | None = None,
            before_period: Callable[[], None] | None = None) -> PaceStats:
        """Advance ``seconds`` of sim time paced, calling ``before_period()`` before each period (after the
        sleep: what arrived while sleeping still applies to it) and ``on_period(readings)`` after it."""
        n = round(seconds / self.period)
        start = anchor_wall = self.clock()
        anchor_sim = 0.0
        done = 0.0
        for _ in range(n):
            if should_stop is not None and should_stop():
                break
            if before_period is not None:
                before_period()
            readings = self.sim.advance(self.ticks)
            if on_period is not None:
                on_period(readings)
            done += self.period
            self.stats.periods += 1
            deadline = anchor_wall + (done - anchor_sim) / self.speed
            now = self.clock()
            if now > deadline:
                self.stats.late += 1
                if now - deadline > self.max_lag:
                    self.stats.slips += 1
                    anchor_wall, anchor_sim = now, done
            else:
                self.sleep(deadline - now)
        self.stats.sim_seconds += done
        self.stats.wall_seconds += self.clock() - start
        return self.stats
