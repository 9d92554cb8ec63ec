"""Warnings at most once per period per cause, with the count of those held back."""

from __future__ import annotations

import logging

from hypothesis import given
from hypothesis import strategies as st

from vilma.core.ratelimit import WarningThrottle


class _Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def _throttle(period: float = 1.0) -> tuple[WarningThrottle, _Clock, list[str]]:
    log = logging.getLogger("test_ratelimit")
    log.propagate = False
    lines: list[str] = []
    log.handlers = [h := logging.Handler()]
    h.emit = lambda record: lines.append(record.getMessage())
    clock = _Clock()
    return WarningThrottle(log, period, clock), clock, lines


def test_a_flood_gives_one_line_a_period_that_counts_the_rest():
    w, clock, lines = _throttle()
    for _ in range(1000):
        w.warning("pose", "dropped a message on %s", "pose")
    assert lines == ["dropped a message on pose"]
    clock.now = 1.5
    w.warning("pose", "dropped a message on %s", "pose")
    assert lines[1] == "dropped a message on pose (999 more like it in the last 1.5 s not shown)"
    w.warning("imu", "dropped a message on %s", "imu")  # another cause is not held back by the first
    assert lines[2] == "dropped a message on imu"


@given(st.lists(st.tuples(st.sampled_from("abc"), st.floats(0.0, 2.0)), max_size=200))
def test_each_cause_at_most_once_a_period_and_none_lost(events):
    """Whatever the timing, per cause: a warning is held back only within a period of the last line, and every
    warning is a line, counted in a later line, or held since the last line."""
    w, clock, lines = _throttle(period=1.0)
    last_line: dict[str, float] = {}
    held_since: dict[str, int] = {}
    for cause, dt in events:
        clock.now += dt
        before = len(lines)
        w.warning(cause, "%s", cause)
        if len(lines) > before:
            assert cause not in last_line or clock.now - last_line[cause] >= 1.0
            last_line[cause], held_since[cause] = clock.now, 0
        else:
            assert clock.now - last_line[cause] < 1.0
            held_since[cause] += 1
    for cause in "abc":
        mine = [line for line in lines if line.startswith(cause)]
        counted = sum(int(line.split("(")[1].split()[0]) for line in mine if "(" in line)
        assert sum(c == cause for c, _ in events) == len(mine) + counted + held_since.get(cause, 0)
