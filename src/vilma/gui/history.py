"""Plot history: fixed-size ring buffers that read back as one contiguous array without copying.

Each sample is written twice, at ``i`` and ``i + capacity`` of a buffer of
``2 * capacity`` rows, so the newest ``capacity`` samples always form one
slice in time order. Columns are stored apart (column-major), so a column of
a view is contiguous for fast reductions. The writer (a bus thread) and the reader (the GUI
thread) share no lock on the data: a reader gets views of rows that are
complete; the oldest ``SAFETY`` rows of a full buffer are left out of a
view because the writer may be overwriting them.
"""

from __future__ import annotations

import threading

import numpy as np

HOUR = 3600.0
"""[s]"""
SAFETY = 16
"""Oldest rows of a full buffer left out of a view (being overwritten while the GUI draws)."""


class RingBuffer:
    """The latest ``capacity`` rows of ``columns`` floats (column 0 is time [s] by convention)."""

    def __init__(self, capacity: int, columns: int) -> None:
        if capacity < 2 * SAFETY or columns < 1:
            raise ValueError(f"ring buffer needs capacity >= {2 * SAFETY} and columns >= 1, "
                             f"got {capacity} and {columns}")
        self.capacity, self.columns = capacity, columns
        self._data = np.full((columns, 2 * capacity), np.nan)
        self._count = 0
        self._lock = threading.Lock()

    def __len__(self) -> int:
        """Rows readable now (at most ``capacity - SAFETY`` once full)."""
        n = self._count
        return n if n < self.capacity else self.capacity - SAFETY

    @property
    def total(self) -> int:
        """Rows appended since the last clear (including those overwritten)."""
        return self._count

    def append(self, row) -> None:
        """Add one row of ``columns`` values."""
        with self._lock:
            i = self._count % self.capacity
            self._data[:, i] = row
            self._data[:, i + self.capacity] = row
            self._count += 1

    def extend(self, rows: np.ndarray) -> None:
        """Add many rows, shape (n, columns), oldest first."""
        rows = np.asarray(rows, dtype=float).reshape(-1, self.columns)
        if len(rows) > self.capacity:
            rows = rows[-self.capacity:]
        with self._lock:
            c, n = self.capacity, len(rows)
            i = self._count % c
            first = min(n, c - i)
            for off in (0, c):
                self._data[:, i + off:i + off + first] = rows[:first].T
                self._data[:, off:off + n - first] = rows[first:].T
            self._count += n

    def view(self) -> np.ndarray:
        """The readable rows in time order, shape (len, columns): a read-only view, not a copy."""
        n, c = self._count, self.capacity
        if n < c:
            out = self._data[:, :n].T
        else:
            start = n % c
            out = self._data[:, start + SAFETY:start + c].T
        out.flags.writeable = False
        return out

    def last(self) -> np.ndarray | None:
        """The newest row, or None if empty."""
        n = self._count
        return None if n == 0 else self._data[:, (n - 1) % self.capacity].copy()

    def clear(self) -> None:
        """Forget every row."""
        with self._lock:
            self._count = 0

    @property
    def nbytes(self) -> int:
        """Memory held [bytes]."""
        return self._data.nbytes


def capacity_for(rate_hz: float, seconds: float = HOUR) -> int:
    """Rows that hold ``seconds`` of history at ``rate_hz`` (plus the safety margin)."""
    return int(np.ceil(rate_hz * seconds)) + 2 * SAFETY
