"""Arrays handed to compiled code as one table of addresses (:mod:`vilma.core.arrays`)."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from vilma.core.arrays import matrix, table, vector

LAYOUT = ((np.float64, 1), (np.int64, 2), (np.int32, 1))


@njit
def _touch(rows):
    """Write through each view of a :data:`LAYOUT` table; the sum of what it then reads."""
    a, b, c = vector(rows, 0, np.float64), matrix(rows, 1, np.int64), vector(rows, 2, np.int32)
    a[-1] += 0.5
    b[1, 2] = 7
    c[0] = -3
    return a.sum() + b.sum() + c.sum()


def test_the_views_are_the_arrays_themselves():
    a, b, c = np.arange(4.0), np.arange(6, dtype=np.int64).reshape(2, 3), np.ones(3, dtype=np.int32)
    rows = table((a, b, c), LAYOUT)
    assert rows.tolist() == [[a.ctypes.data, 4, 0], [b.ctypes.data, 2, 3], [c.ctypes.data, 3, 0]]
    total = _touch(rows)
    assert a.tolist() == [0.0, 1.0, 2.0, 3.5] and b.tolist() == [[0, 1, 2], [3, 4, 7]] and c.tolist() == [-3, 1, 1]
    assert total == a.sum() + b.sum() + c.sum()


@njit
def _sizes(rows):
    return vector(rows, 0, np.float64).size, matrix(rows, 1, np.int64).shape


def test_empty_arrays_are_empty_views():  # (a car without obstacles has no contact sensors)
    assert _sizes(table((np.zeros(0), np.zeros((0, 3), np.int64)), LAYOUT[:2])) == (0, (0, 3))


@pytest.mark.parametrize(("arrays", "message"), [
    ((np.zeros(2, np.float32), np.zeros((1, 1), np.int64), np.zeros(1, np.int32)),
     "row 0: a 1-d float32 array (C-contiguous: True) where compiled code reads a C-contiguous 1-d float64 one"),
    ((np.zeros(2), np.zeros(3, np.int64), np.zeros(1, np.int32)),
     "row 1: a 1-d int64 array (C-contiguous: True) where compiled code reads a C-contiguous 2-d int64 one"),
    ((np.zeros(2), np.zeros((3, 3), np.int64).T, np.zeros(1, np.int32)),
     "row 1: a 2-d int64 array (C-contiguous: False) where compiled code reads a C-contiguous 2-d int64 one"),
    ((np.zeros(2), np.zeros((3, 3), np.int64), np.zeros(4, np.int32)[::2]),
     "row 2: a 1-d int32 array (C-contiguous: False) where compiled code reads a C-contiguous 1-d int32 one"),
])
def test_a_table_refuses_an_array_its_reader_would_misread(arrays, message):
    with pytest.raises(TypeError) as e:
        table(arrays, LAYOUT)
    assert str(e.value) == message


def test_a_table_needs_every_row():
    with pytest.raises(ValueError):
        table((np.zeros(2), np.zeros((1, 1), np.int64)), LAYOUT)
