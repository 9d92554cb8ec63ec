"""What a run keeps: the car and the driver at every control period; the sensors streamed to a CSV.

The rows live in a growing numpy buffer (one float64 row a period: an hour is
about 30 MB), never one Python object a sample. Sensor readings are not kept:
:class:`TimeseriesWriter` merges them with the rows and appends them to
``timeseries.csv`` every few hundred periods, so memory stays flat however
long the drive.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import msgspec
import numpy as np

from vilma.core.files import write_error
from vilma.sensors import Readings, Sensor

COLUMNS = (
    "t",  # sim time [s]
    "x", "y", "yaw", "vx", "vy", "yaw_rate", "steer",  # the plant (truth): m, rad, m/s, rad/s, rad
    "drive_force", "brake_force",  # applied [N]
    "target_speed", "measured_speed",  # the driver's [m/s]
    "est_x", "est_y", "est_yaw",  # the pose the driver steered by (NaN before it has one)
    "cmd_steer", "cmd_drive", "cmd_brake",  # commanded: rad; drive in the command's unit (N, m/s^2 or power)
    "controller_us",  # wall time of the driver's update [us]
)
"""Columns of :attr:`DriveLog.rows`, with units."""
MAX_ROWS = 4_320_000
"""Most rows a run keeps: a day of sim time at the default 50 Hz driver, 0.66 GB (a scenario's ``duration`` is
held to it)."""
PLANT_COLUMNS = COLUMNS[1:COLUMNS.index("target_speed")]
"""The columns of the true plant (``car.*`` in the CSV); the rest are the driver's (``driver.*``)."""
SIM_COLUMNS = COLUMNS.index("controller_us")
"""The columns before this one are sim-time values; ``controller_us`` (wall clock) stays out of the CSV, so
that two runs of one scenario write the same bytes."""

_json = msgspec.json.Encoder()


class DriveLog:
    """Rows of :data:`COLUMNS`, one a control period."""

    def __init__(self, capacity: int = 4096) -> None:
        self._rows = np.empty((capacity, len(COLUMNS)))
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def add(self, row) -> None:
        """Append one row of :data:`COLUMNS` values."""
        if self._n == len(self._rows):
            self._rows = np.concatenate([self._rows, np.empty_like(self._rows)])
        self._rows[self._n] = row
        self._n += 1

    def extend(self, rows: np.ndarray) -> None:
        """Append rows (k, len(COLUMNS))."""
        while self._n + len(rows) > len(self._rows):
            self._rows = np.concatenate([self._rows, np.empty_like(self._rows)])
        self._rows[self._n:self._n + len(rows)] = rows
        self._n += len(rows)

    @property
    def rows(self) -> np.ndarray:
        """The rows so far, (n, len(COLUMNS)) (a view)."""
        return self._rows[: self._n]

    def column(self, name: str) -> np.ndarray:
        """One column of :attr:`rows`, (n,)."""
        return self.rows[:, COLUMNS.index(name)]


class TimeseriesWriter:
    """Streams one CSV: a row per stamp, the log's columns at the control period, each sensor at its rate.

    Column names are ``t_s`` (sim time [s]), ``car.<column>`` (the true plant), ``driver.<column>`` and
    ``<sensor>.<field>``; a cell is empty where that signal has no sample at that stamp. The file is
    written as ``<path>.part`` and renamed by :meth:`close`.
    """

    BLOCK = 256
    """Control periods merged and written at a time."""

    def __init__(self, path: Path, sensors: list[Sensor], log: DriveLog) -> None:
        self.path, self.log = path, log
        self._written = 0
        self._names = sorted(s.name for s in sensors)
        fields = {s.name: s.message.__struct_fields__[1:] for s in sensors}
        self._widths = [len(fields[n]) for n in self._names]
        driver = COLUMNS[1 + len(PLANT_COLUMNS):SIM_COLUMNS]
        header = (["t_s"] + [f"car.{c}" for c in PLANT_COLUMNS] + [f"driver.{c}" for c in driver]
                  + [f"{n}.{f}" for n in self._names for f in fields[n]])
        self._width = len(header)
        self._part = path.with_name(path.name + ".part")
        self._file = self._part.open("wb")
        self._file.write((",".join(header) + "\n").encode())
        self._readings: dict[str, list[Readings]] = {n: [] for n in self._names}

    def add(self, readings: dict[str, Readings]) -> None:
        """The readings of one control period, after its row went into the log."""
        for name, r in readings.items():
            if len(r):
                self._readings[name].append(r)
        if len(self.log) - self._written >= self.BLOCK:
            self._flush()

    def _flush(self) -> None:
        rows = self.log.rows[self._written:]
        self._written += len(rows)
        groups = [(np.round(rows[:, 0] * 1e9).astype(np.int64), rows[:, 1:SIM_COLUMNS])]
        for name, width in zip(self._names, self._widths, strict=True):
            parts = self._readings[name]
            r = Readings.concat(parts) if parts else None
            groups.append((r.stamp_ns, r.values) if r is not None else (np.empty(0, np.int64), np.empty((0, width))))
        stamps = np.unique(np.concatenate([g[0] for g in groups]))
        table = np.full((len(stamps), self._width), np.nan)
        table[:, 0] = stamps * 1e-9
        col = 1
        for st, values in groups:
            table[np.searchsorted(stamps, st), col:col + values.shape[1]] = values
            col += values.shape[1]
        for parts in self._readings.values():
            parts.clear()
        try:
            self._file.write(csv_lines(table))
        except OSError as e:
            raise write_error(self.path, e) from None

    def close(self) -> Path:
        """Write what is left and put the file in place; returns its path."""
        self._flush()
        try:
            self._file.close()
            self._part.replace(self.path)
        except OSError as e:
            raise write_error(self.path, e) from None
        return self.path

    def abort(self) -> None:
        """Drop the partial file (the run failed)."""
        with contextlib.suppress(OSError):  # what could not be written is dropped with it
            self._file.close()
        self._part.unlink(missing_ok=True)


def csv_lines(table: np.ndarray) -> bytes:
    """Rows of numbers as CSV lines: shortest exact floats, an empty cell for NaN (infinity as ``inf``)."""
    if not len(table):
        return b""
    if np.isinf(table).any():  # JSON has no infinity: the slow way
        return "".join(",".join("" if v != v else repr(v) for v in line) + "\n" for line in table.tolist()).encode()
    # a JSON line a row, [a,b] and [c,null]: the same digits as repr, in one C call; then no brackets nor nulls, in
    # one pass (a finite float's digits, '.', 'e', '+' and '-' hold no 'n', 'u' nor 'l')
    return _json.encode_lines(table.tolist()).translate(None, b"[]nul")
