"""Ring buffers of the plot history: order, wrap-around, capacity for an hour."""

from __future__ import annotations

import numpy as np
import pytest

from vilma.gui.history import HOUR, SAFETY, RingBuffer, capacity_for


def test_rows_come_back_in_time_order_before_and_after_wrapping():
    cap = 100
    rb = RingBuffer(cap, 2)
    rows = np.column_stack([np.arange(250.0), np.arange(250.0) ** 2])
    for r in rows[:60]:
        rb.append(r)
    assert np.array_equal(rb.view(), rows[:60])
    for r in rows[60:]:
        rb.append(r)
    v = rb.view()
    assert len(v) == cap - SAFETY == len(rb)
    assert np.array_equal(v, rows[250 - cap + SAFETY:])  # the newest rows, oldest first
    assert np.array_equal(rb.last(), rows[-1])
    assert not v.flags.writeable


def test_extend_equals_appending_row_by_row():
    a, b = RingBuffer(64, 3), RingBuffer(64, 3)
    rows = np.random.default_rng(1).normal(size=(150, 3))
    for r in rows:
        a.append(r)
    b.extend(rows[:40])
    b.extend(rows[40:])
    assert np.array_equal(a.view(), b.view())
    b.clear()
    assert len(b) == 0 and b.last() is None


def test_an_hour_at_100_hz_fits_and_bad_sizes_are_refused():
    assert capacity_for(100.0) - 2 * SAFETY == 360_000 == round(100 * HOUR)
    with pytest.raises(ValueError, match="capacity"):
        RingBuffer(3, 2)
