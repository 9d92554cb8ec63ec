"""Recording as the original's Record Trajectory and Record Speed buttons, timed by sim time.

``PositionLog``: one ``"%f\\t%f\\n"`` line of x, y [m] at once, then one every
period (250 ms). ``SpeedLog``: the original's Portuguese header, then
``"%lf\\t%f\\n"`` lines of time since the start [s] and speed [m/s].
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from vilma.trajectory.io import _fail, _number, _read_text

SPEED_LOG_HEADER = "Tempo desde o começo da simulação\tMódulo da velocidade do veículo"


class _Recorder:
    def __init__(self, path: str | os.PathLike, period: float = 0.25, header: str | None = None) -> None:
        if not period > 0:
            raise ValueError(f"recording period must be > 0 s, got {period!r}")
        self.path, self.period_ns = Path(path), round(period * 1e9)
        self._file = open(self.path, "w", encoding="utf-8")  # noqa: SIM115 (closed in close())
        if header is not None:
            self._file.write(header + "\n")
        self._start_ns: int | None = None
        self._next_ns = 0

    def _due(self, stamp_ns: int) -> bool:
        if self._start_ns is None:
            self._start_ns, self._next_ns = stamp_ns, stamp_ns
        if stamp_ns < self._next_ns:
            return False
        self._next_ns += self.period_ns * max(1, (stamp_ns - self._next_ns) // self.period_ns + 1)
        return True

    def close(self) -> None:
        """Flush and close the file."""
        self._file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class TrajectoryRecorder(_Recorder):
    """Writes the car's position to a ``PositionLog`` file every ``period`` [s] of sim time."""

    def add(self, stamp_ns: int, x: float, y: float) -> None:
        """Offer a position sample (in time order); written when a period is due."""
        if self._due(stamp_ns):
            self._file.write(f"{x:f}\t{y:f}\n")


class SpeedRecorder(_Recorder):
    """Writes (time since start, speed) to a ``SpeedLog`` file every ``period`` [s] of sim time."""

    def __init__(self, path: str | os.PathLike, period: float = 0.25) -> None:
        super().__init__(path, period, SPEED_LOG_HEADER)

    def add(self, stamp_ns: int, speed: float) -> None:
        """Offer a speed sample (in time order); written when a period is due."""
        if self._due(stamp_ns):
            self._file.write(f"{(stamp_ns - self._start_ns) / 1e9:f}\t{speed:f}\n")


def load_speed_log(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """Read a ``SpeedLog`` file (a header line, then a time and a speed a line): times [s] and speeds [m/s].

    Raises:
        TrajectoryFileError: a missing, unreadable or too large file, or a line that is not two finite numbers.
    """
    path = Path(path)
    rows = []
    for n, line in enumerate(_read_text(path).splitlines()[1:], start=2):
        if row := line.split():
            if len(row) != 2:
                raise _fail(path, n, f"{len(row)} values; a speed log has a time [s] and a speed [m/s] a line")
            rows.append([_number(token, path, n, "value") for token in row])
    if not rows:
        raise _fail(path, None, "no samples; a speed log has a header line, then a time [s] and a speed [m/s] a line")
    data = np.array(rows)
    return data[:, 0], data[:, 1]
