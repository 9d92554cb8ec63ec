"""The paced simulator's real-time factor: sim seconds per wall second over the last second, however sim time runs."""

from __future__ import annotations

import math

import pytest

from vilma.bus.paced import RATE_WINDOW, RateMeter


def test_the_factor_is_frames_of_sim_time_over_the_wall_time_of_the_last_window():
    """Frames, not the sim clock: a reset (sim time back to 0) is one more 20 ms frame (the factor read 0.12-0.30 at
    1x for seconds after a reset, from the clock's jump)."""
    meter = RateMeter(0.02, now=100.0)
    assert math.isnan(meter.frame(100.0))  # no wall time yet
    wall = 100.0
    for _ in range(100):  # a 20 ms frame every 40 ms of wall time: half real time
        wall += 0.04
        factor = meter.frame(wall)
    assert factor == pytest.approx(0.5)
    for _ in range(round(RATE_WINDOW / 0.01) + 1):  # then one every 10 ms, for a whole window: twice real time
        wall += 0.01
        factor = meter.frame(wall)
    assert factor == pytest.approx(2.0)

