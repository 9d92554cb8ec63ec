"""What every sensor shares: the samples it reads and the readings it makes."""

from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Protocol

import msgspec
import numpy as np
from numba import njit

from vilma.core.messages import Message
from vilma.vehicle.state import N3

NO_3D = np.zeros((0, N3))
"""The 3D records of a planar plant: none (flat ground: no height, roll or pitch). Compiled code takes it as a
constant."""


@dataclass(frozen=True, slots=True)
class Samples:
    """The plant at a sensor's sample ticks: rows ``rows`` of the recorded arrays.

    Attributes:
        rows: indices of this sensor's samples in ``z`` and ``dx``, shape (n,).
        z: recorded plant vectors (layout of :mod:`vilma.vehicle.state`), shape (m, NZ), m >= n.
        dx: recorded vehicle state derivatives, shape (m, NX).
        extra: what only the 3D plant records (layout :data:`~vilma.vehicle.state.N3`), shape (m, N3), or
            :data:`NO_3D` for a planar plant.
    """

    rows: np.ndarray
    z: np.ndarray
    dx: np.ndarray
    extra: np.ndarray = field(default_factory=lambda: NO_3D)

    def __len__(self) -> int:
        return len(self.rows)


@njit(cache=True)
def rows_of(ticks, period, count):
    """Indices of the ``count`` entries of ``ticks`` that are multiples of ``period``."""
    out = np.empty(count, dtype=np.int64)
    k = 0
    for i in range(ticks.shape[0]):
        if ticks[i] % period == 0:
            out[k] = i
            k += 1
    return out


class Readings(msgspec.Struct, gc=False, eq=False):
    """Readings of one sensor: ``values[i]`` holds the fields of ``message`` (after ``stamp_ns``) at ``stamp_ns[i]``.

    ``Readings(name, message, stamp_ns, values, lo, hi)``: given ``lo`` and ``hi``, the readings are rows ``lo:hi`` of
    the arrays, cut out on each access: a 20 ms frame makes seven readings (:class:`~vilma.sensors.bank.SensorBank`),
    and cutting their views at once costs a microsecond a frame, a sixth of it, whether they are looked at or not. A
    struct (made in C, untracked by the garbage collector: it holds no cycle) rather than a class: made for half the
    cost, a fifth of a frame's Python.
    """

    name: str
    """The sensor's name."""
    message: type[Message]
    """The message type of a reading."""
    _stamp_ns: np.ndarray
    _values: np.ndarray
    _lo: int = 0
    _hi: int | None = None

    @property
    def stamp_ns(self) -> np.ndarray:
        """Stamps [ns], shape (n,)."""
        return self._stamp_ns if self._hi is None else self._stamp_ns[self._lo:self._hi]

    @property
    def values(self) -> np.ndarray:
        """Values, shape (n, fields of ``message`` after ``stamp_ns``)."""
        return self._values if self._hi is None else self._values[self._lo:self._hi]

    def __repr__(self) -> str:
        return f"Readings({self.name!r}, {self.message.__name__}, {len(self)} readings)"

    def __reduce__(self) -> tuple:
        return Readings, (self.name, self.message, self.stamp_ns, self.values)  # the rows only, not their blocks

    def __len__(self) -> int:
        return len(self._stamp_ns) if self._hi is None else self._hi - self._lo

    def latest(self) -> Message | None:
        """The newest reading as a message, or None if there is none."""
        return self.at(-1) if len(self) else None

    def at(self, i: int) -> Message:
        """Reading ``i`` as a message."""
        return self.message(int(self.stamp_ns[i]), *self.values[i].tolist())

    def messages(self) -> list[Message]:
        """Every reading as a message, oldest first."""
        return [self.message(int(t), *row) for t, row in zip(self.stamp_ns.tolist(), self.values.tolist(),
                                                               strict=True)]

    def field(self, name: str) -> np.ndarray:
        """One field over all readings, shape (n,)."""
        return self.values[:, self.message.__struct_fields__.index(name) - 1]

    @staticmethod
    def concat(parts: list[Readings]) -> Readings:
        """Join readings of one sensor in time order."""
        first = parts[0]
        if len(parts) == 1:
            return first
        return Readings(first.name, first.message, np.concatenate([r.stamp_ns for r in parts]),
                        np.concatenate([r.values for r in parts]))


class Sensor(Protocol):
    """A sensor: ``name``, ``message`` type and ``rate_hz``; :meth:`measure` maps samples to value rows."""

    name: str
    message: type[Message]
    rate_hz: float

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        """Start over from plant vector ``z0`` with a fresh noise generator."""

    def measure(self, s: Samples) -> np.ndarray:
        """Value rows for samples ``s``, shape (len(s), number of message fields after the stamp)."""


def sensor_rng(seed: int, name: str) -> np.random.Generator:
    """The noise generator of sensor ``name`` for run ``seed``: independent of which other sensors exist."""
    return np.random.Generator(np.random.PCG64(_seeds(seed, name)))  # as np.random.default_rng([seed, crc])


@lru_cache(maxsize=256)  # hashing the seed is most of the cost of a generator, and a run makes one per sensor
def _seeds(seed: int, name: str) -> np.random.SeedSequence:
    return np.random.SeedSequence([seed, zlib.crc32(name.encode())])
