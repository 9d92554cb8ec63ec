"""The timeseries CSV text: every float back exactly, NaN as an empty cell, infinity as inf."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from vilma.scenario.drive_log import csv_lines


def _read(text: str) -> np.ndarray:
    return np.array([[float(c) if c else math.nan for c in line.split(",")] for line in text.splitlines()])


@given(arrays(np.float64, st.tuples(st.integers(1, 6), st.integers(1, 5)), elements=st.floats()))
def test_csv_lines_give_back_every_value(table):
    text = csv_lines(table).decode()
    assert text.endswith("\n") and text.count("\n") == len(table)
    back, known = _read(text), ~np.isnan(table)
    assert np.array_equal(back, table, equal_nan=True)
    assert np.array_equal(np.signbit(back[known]), np.signbit(table[known]))  # -0.0 stays -0.0


def test_nan_is_an_empty_cell_and_infinity_is_written():
    assert csv_lines(np.array([[0.5, math.nan, 2.0]])) == b"0.5,,2.0\n"
    assert csv_lines(np.array([[math.inf, math.nan]])) == b"inf,\n"
    assert csv_lines(np.empty((0, 3))) == b""
