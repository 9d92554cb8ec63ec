"""The one simulation clock: an integer tick and a fixed physics step.

Sim time is ``tick * step_ns`` in integer nanoseconds, so it never drifts and
every sensor or controller period is an exact whole number of ticks.
"""

from __future__ import annotations

import math

NS_PER_S = 1_000_000_000
MAX_NS = 2**63 - 1
"""The longest time the clock counts [ns] (int64, about 292 years)."""


class RateError(ValueError):
    """A rate or period that is not a whole multiple of the physics step."""


def seconds_to_ns(seconds: float) -> int:
    """Seconds -> integer nanoseconds (rounded to the nearest ns), within +-:data:`MAX_NS`."""
    if not abs(seconds) * NS_PER_S < MAX_NS:  # NaN fails too
        raise ValueError(f"time must be finite and within +-{MAX_NS / NS_PER_S:.3g} s (the clock counts int64 ns), "
                         f"got {seconds!r}")
    return round(seconds * NS_PER_S)


class Clock:
    """Integer-tick clock with a fixed physics step.

    Args:
        step_ns: physics step [ns], > 0.
    """

    __slots__ = ("step_ns", "tick")

    def __init__(self, step_ns: int) -> None:
        if not isinstance(step_ns, int) or step_ns <= 0:
            raise RateError(f"physics step must be a positive whole number of ns, got {step_ns!r}")
        self.step_ns = step_ns
        self.tick = 0

    @property
    def step_s(self) -> float:
        """Physics step [s]."""
        return self.step_ns / NS_PER_S

    @property
    def time_ns(self) -> int:
        """Sim time [ns]."""
        return self.tick * self.step_ns

    @property
    def time_s(self) -> float:
        """Sim time [s]."""
        return self.time_ns / NS_PER_S

    def ticks_for(self, seconds: float) -> int:
        """Whole ticks in ``seconds`` (rounded to the nearest tick)."""
        return round(seconds_to_ns(seconds) / self.step_ns)

    def period_ticks(self, rate_hz: float, what: str) -> int:
        """Ticks per period of something running at ``rate_hz``.

        Raises:
            RateError: the period is not a whole multiple of the physics step,
                naming ``what`` and the nearest rates that would work.
        """
        if not (isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and rate_hz > 0):
            raise RateError(f"{what}: rate must be a positive number of Hz, got {rate_hz!r}")
        period_ns = NS_PER_S / rate_hz
        if period_ns > MAX_NS:
            raise RateError(f"{what}: {rate_hz:g} Hz is a period longer than the clock counts "
                            f"({MAX_NS / NS_PER_S:.3g} s)")
        ticks = period_ns / self.step_ns
        if abs(ticks - round(ticks)) > 1e-9 * max(1.0, ticks) or round(ticks) < 1:
            lo = max(1, math.floor(ticks))
            hi = lo + 1
            raise RateError(
                f"{what}: {rate_hz:g} Hz is a period of {period_ns / 1e6:g} ms, not a whole multiple of the "
                f"{self.step_ns / 1e6:g} ms physics step; use {self.rate_of(hi):g} Hz or {self.rate_of(lo):g} Hz, "
                f"or change the step"
            )
        return round(ticks)

    def rate_of(self, ticks: int) -> float:
        """Rate [Hz] of something that runs every ``ticks`` ticks."""
        return NS_PER_S / (ticks * self.step_ns)
