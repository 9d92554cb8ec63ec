"""ROS 2 messages in CDR: fixed-size ones packed in bulk into MCAP Message records, and single ones with arrays.

A message whose every field has a fixed size (vilma's numeric topics; strings,
such as a header's ``frame_id``, are constants) is a byte template with slots:
the stamp (``builtin_interfaces/Time``: int32 sec, uint32 nanosec) and float64
values. :class:`CdrBody` lays out such a body as CDR does (little endian, each field aligned to its size from the body's
start, after the 4-byte encapsulation header); :func:`pack_records` writes the
MCAP records of a whole column of messages in one compiled loop (in the
recorder's process of a ``vilma run``, on another core than the car's loop).
A message with arrays (an image, a scan) is a :class:`CdrBody` of constants only (the stamp given, arrays
with :meth:`CdrBody.sequence`), one message at a time; :class:`CdrReader` reads one back.
"""

from __future__ import annotations

import functools
import struct

import numpy as np
from mcap.opcode import Opcode
from numba import njit

from vilma.record.mcap_file import MESSAGE_HEADER

ENCAPSULATION = b"\x00\x01\x00\x00"
"""CDR, little endian: the first four bytes of every payload."""
RECORD_HEADER = MESSAGE_HEADER.size
"""An MCAP Message record's opcode, length, channel, sequence, log and publish time [bytes]."""
_TIMES = (15, 23)
"""Where a Message record's log time and publish time start [bytes]."""


class CdrBody:
    """A fixed-size CDR message under construction: constant bytes, and slots for the stamp and float64s."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.slots: list[int] = []
        """Offsets of the slots in the body [bytes]."""

    def _align(self, size: int) -> None:
        self.data += bytes(-len(self.data) % size)

    def time(self, stamp_ns: int | None = None) -> CdrBody:
        """A ``builtin_interfaces/Time`` (int32 sec, uint32 nanosec): ``stamp_ns`` [ns], or if None a slot of its
        own filled from the stamp."""
        self._align(4)
        if stamp_ns is None:
            self.slots.append(len(self.data))
        self.data += struct.pack("<iI", *divmod(stamp_ns or 0, 1_000_000_000))
        return self

    def header(self, frame_id: str, stamp_ns: int | None = None) -> CdrBody:
        """A ``std_msgs/Header``: the stamp (as :meth:`time`) and a constant ``frame_id``."""
        return self.time(stamp_ns).string(frame_id)

    def string(self, text: str) -> CdrBody:
        """A constant string."""
        self._align(4)
        raw = text.encode() + b"\0"
        self.data += struct.pack("<I", len(raw)) + raw
        return self

    def float64(self, count: int = 1) -> CdrBody:
        """``count`` float64 slots."""
        self._align(8)
        for _ in range(count):
            self.slots.append(len(self.data))
            self.data += bytes(8)
        return self

    def zeros(self, count: int, size: int) -> CdrBody:
        """``count`` constant zero numbers of ``size`` bytes (a covariance unknown, an enum's first value)."""
        self._align(size)
        self.data += bytes(count * size)
        return self

    def number(self, fmt: str, *values: float) -> CdrBody:
        """Constant numbers of ``struct`` format ``fmt`` (``b`` int8, ``H`` uint16, ``f`` float32...): an enum's
        value, a fixed-size array."""
        self._align(struct.calcsize(fmt))
        self.data += struct.pack(f"<{len(values)}{fmt}", *values)
        return self

    def sequence(self, data: bytes, size: int = 1) -> CdrBody:
        """A constant sequence (``uint8[]``, ``float32[]``...) of ``len(data) // size`` numbers of ``size`` bytes,
        ``data`` little-endian."""
        self._align(4)
        self.data += struct.pack("<I", len(data) // size)
        self._align(size)
        self.data += data
        return self

    def payload(self) -> tuple[bytes, tuple[int, ...]]:
        """The payload template (encapsulation header and body) and its slots' offsets in it."""
        return ENCAPSULATION + bytes(self.data), tuple(4 + s for s in self.slots)


def stamps_of(sec: np.ndarray, nanosec: np.ndarray) -> np.ndarray:
    """Sim times [ns] of ``builtin_interfaces/Time`` fields."""
    return sec.astype(np.int64) * 1_000_000_000 + nanosec.astype(np.int64)


@functools.cache
def runs(slots: tuple[int, ...]) -> tuple[tuple[int, int, int], ...]:
    """The float64 slots (``slots[1:]``) as runs side by side: (offset, index of the first float, count)."""
    out: list[list[int]] = []
    for i, at in enumerate(slots[1:]):
        if out and out[-1][0] + 8 * out[-1][2] == at:
            out[-1][2] += 1
        else:
            out.append([at, i, 1])
    return tuple(tuple(r) for r in out)


@njit(nogil=True, cache=True)
def _pack(out, template, time_at, float_runs, stamps, float_bytes):
    for i in range(out.shape[0]):
        row, t = out[i], stamps[i]
        row[:] = template
        sec, nanosec = t // 1_000_000_000, t % 1_000_000_000
        for b in range(8):
            byte = (t >> (8 * b)) & 0xFF
            row[_TIMES[0] + b] = byte
            row[_TIMES[1] + b] = byte
        for b in range(4):
            row[time_at + b] = (sec >> (8 * b)) & 0xFF
            row[time_at + 4 + b] = (nanosec >> (8 * b)) & 0xFF
        for r in range(float_runs.shape[0]):
            at, first, size = float_runs[r, 0], 8 * float_runs[r, 1], 8 * float_runs[r, 2]
            row[at:at + size] = float_bytes[i, first:first + size]


def pack_records(payload: bytes, slots: tuple[int, ...], channel: int, stamps: np.ndarray, values: np.ndarray,
                 out: np.ndarray | None = None) -> np.ndarray:
    """The MCAP Message records of ``len(stamps)`` messages on ``channel``, one after the other.

    ``payload`` and ``slots`` come from :meth:`CdrBody.payload` (the stamp's slot first, then the float64 ones);
    ``stamps`` [ns] are the log and publish times and the stamp (``builtin_interfaces/Time`` holds 68 years),
    ``values`` (n, len(slots) - 1) the float64s.
    Returns the records' bytes (uint8, in ``out`` if given); each is ``RECORD_HEADER + len(payload)`` long.
    """
    head = MESSAGE_HEADER.pack(Opcode.MESSAGE, 22 + len(payload), channel, 0, 0, 0)
    template = np.frombuffer(head + payload, np.uint8)
    values = np.ascontiguousarray(values, np.float64)
    out = np.empty(len(stamps) * len(template), np.uint8) if out is None else out
    float_runs = np.array([(RECORD_HEADER + at, first, n) for at, first, n in runs(slots)], np.int64)
    _pack(out.reshape(len(stamps), len(template)), template, RECORD_HEADER + slots[0], float_runs,
          np.asarray(stamps, np.int64), values.view(np.uint8).reshape(len(values), -1))
    return out


def payload_dtype(payload: bytes, slots: tuple[int, ...]) -> np.dtype:
    """A structured dtype reading a payload's stamp (``sec``, ``nanosec``) and float64s (``f0``, ``f1``...)."""
    floats = [f"f{i}" for i in range(len(slots) - 1)]
    return np.dtype({"names": ["sec", "nanosec", *floats], "formats": ["<i4", "<u4", *["<f8"] * len(floats)],
                     "offsets": [slots[0], slots[0] + 4, *slots[1:]], "itemsize": len(payload)})


class CdrReader:
    """Reads one CDR payload field by field, in the order :class:`CdrBody` writes them.

    Raises:
        ValueError: not little-endian CDR, or the payload ends before a field.
    """

    def __init__(self, payload: bytes) -> None:
        if payload[:4] != ENCAPSULATION:
            raise ValueError(f"not little-endian CDR (starts {payload[:4].hex() or 'empty'})")
        self.data, self.at = memoryview(payload)[4:], 0

    def _take(self, size: int, align: int) -> memoryview:
        self.at += -self.at % align
        if self.at + size > len(self.data):
            raise ValueError(f"the payload ends at byte {len(self.data) + 4}, before a field of {size} bytes")
        self.at += size
        return self.data[self.at - size:self.at]

    def number(self, fmt: str, count: int = 1):
        """The next ``count`` numbers of ``struct`` format ``fmt`` (one number if ``count`` is 1)."""
        size = struct.calcsize(fmt)
        out = struct.unpack(f"<{count}{fmt}", self._take(count * size, size))
        return out[0] if count == 1 else out

    def time(self) -> int:
        """A ``builtin_interfaces/Time`` [ns]."""
        sec, nanosec = self.number("i"), self.number("I")
        return sec * 1_000_000_000 + nanosec

    def string(self) -> str:
        """A string (without its terminating NUL)."""
        return bytes(self.sequence())[:-1].decode()

    def sequence(self, size: int = 1) -> memoryview:
        """The bytes of a sequence of numbers of ``size`` bytes each."""
        count = self.number("I")
        return self._take(count * size, size)
