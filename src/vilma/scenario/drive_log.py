"""What a run keeps: the car and the driver at every control period, and every sensor reading at its rate.

Held in growing numpy buffers (one float64 row a period, readings as the
simulator's arrays), never as one Python object a sample: an hour at default
rates is a few tens of MB.
"""

from __future__ import annotations

import numpy as np

from vilma.sensors import Readings

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


_CHUNK = 256
"""Simulator calls whose readings are joined into one array."""


class DriveLog:
    """Rows of :data:`COLUMNS` a control period, and readings by sensor name."""

    def __init__(self, capacity: int = 4096) -> None:
        self._rows = np.empty((capacity, len(COLUMNS)))
        self._n = 0
        self._readings: dict[str, list[Readings]] = {}  # joined chunks, then the latest calls' readings
        self._chunks: dict[str, int] = {}

    def __len__(self) -> int:
        return self._n

    def add(self, row) -> None:
        """Append one row of :data:`COLUMNS` values."""
        if self._n == len(self._rows):
            self._rows = np.concatenate([self._rows, np.empty_like(self._rows)])
        self._rows[self._n] = row
        self._n += 1

    def add_readings(self, readings: dict[str, Readings]) -> None:
        """Keep one simulator call's readings."""
        for name, r in readings.items():
            if len(r):
                parts = self._readings.setdefault(name, [])
                parts.append(r)
                done = self._chunks.get(name, 0)
                if len(parts) - done >= _CHUNK:  # join the latest calls: arrays, not objects, pile up
                    parts[done:] = [Readings.concat(parts[done:])]
                    self._chunks[name] = done + 1

    @property
    def rows(self) -> np.ndarray:
        """The rows so far, (n, len(COLUMNS)) (a view)."""
        return self._rows[: self._n]

    def column(self, name: str) -> np.ndarray:
        """One column of :attr:`rows`, (n,)."""
        return self.rows[:, COLUMNS.index(name)]

    def readings(self) -> dict[str, Readings]:
        """Every reading of each sensor, joined in time order."""
        return {name: Readings.concat(parts) for name, parts in self._readings.items()}
