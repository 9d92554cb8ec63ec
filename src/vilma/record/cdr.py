"""Fixed-size ROS 2 messages in CDR, packed in bulk into MCAP Message records.

A message whose every field has a fixed size (vilma's numeric topics) is a
byte template with 8-byte words in slots: the stamp (``builtin_interfaces/Time``:
int32 sec, uint32 nanosec) and float64 values. :class:`CdrBody` lays out such a
body as CDR does (little endian, each field aligned to its size from the body's
start, after the 4-byte encapsulation header); :func:`pack_records` writes the
MCAP records of a whole column of messages in one compiled loop that releases
the GIL, so a recording thread packs on another core while the car drives.
"""

from __future__ import annotations

import struct

import numpy as np
from numba import njit

ENCAPSULATION = b"\x00\x01\x00\x00"
"""CDR, little endian: the first four bytes of every payload."""
RECORD_HEADER = 31
"""An MCAP Message record's opcode, length, channel, sequence, log and publish time [bytes]."""
_TIMES = (15, 23)
"""Where a Message record's log time and publish time start [bytes]."""


class CdrBody:
    """A fixed-size CDR message under construction: constant bytes, and slots for 8-byte words."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.slots: list[int] = []
        """Offsets of the words in the body [bytes]."""

    def _align(self, size: int) -> None:
        self.data += bytes(-len(self.data) % size)

    def time(self) -> CdrBody:
        """A ``builtin_interfaces/Time`` filled from the stamp (a slot)."""
        self._align(4)
        self.slots.append(len(self.data))
        self.data += bytes(8)
        return self

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

    def payload(self) -> tuple[bytes, tuple[int, ...]]:
        """The payload template (encapsulation header and body) and its slots' offsets in it."""
        return ENCAPSULATION + bytes(self.data), tuple(4 + s for s in self.slots)


def stamp_words(stamps: np.ndarray) -> np.ndarray:
    """``builtin_interfaces/Time`` of sim times [ns] as one little-endian word each (sec, then nanosec)."""
    st = np.asarray(stamps, np.int64)
    return ((st // 1_000_000_000) & 0xFFFFFFFF).astype(np.uint64) | ((st % 1_000_000_000).astype(np.uint64) << 32)


def stamps_of(words: np.ndarray) -> np.ndarray:
    """The sim times [ns] of :func:`stamp_words`."""
    w = np.asarray(words, np.uint64)
    sec = (w & 0xFFFFFFFF).astype(np.uint32).view(np.int32).astype(np.int64)
    return sec * 1_000_000_000 + (w >> 32).astype(np.int64)


@njit(nogil=True, cache=True)
def _pack(out, template, runs, word_bytes):
    for i in range(out.shape[0]):
        row, src = out[i], word_bytes[i]
        row[:] = template
        for r in range(runs.shape[0]):
            at, start, size = runs[r, 0], runs[r, 1], runs[r, 2]
            row[at:at + size] = src[start:start + size]


def _runs(slots: tuple[int, ...]) -> np.ndarray:
    """Slots side by side as runs: (offset in the record, offset in the row's words, length) [bytes]."""
    runs: list[list[int]] = []
    for j, at in enumerate(slots):
        if runs and runs[-1][0] + runs[-1][2] == at:
            runs[-1][2] += 8
        else:
            runs.append([at, 8 * j, 8])
    return np.array(runs, np.int64)


def pack_records(payload: bytes, slots: tuple[int, ...], channel: int, stamps: np.ndarray,
                 words: np.ndarray) -> np.ndarray:
    """The MCAP Message records of ``len(stamps)`` messages on ``channel``, one after the other.

    ``payload`` and ``slots`` come from :meth:`CdrBody.payload`; ``words`` (n, len(slots)) holds each message's
    words (uint64, or float64 taken bit for bit). Returns the records' bytes (uint8); each is
    ``RECORD_HEADER + len(payload)`` long.
    """
    n = len(stamps)
    head = struct.pack("<BQHIQQ", 5, 22 + len(payload), channel, 0, 0, 0)
    template = np.frombuffer(head + payload, np.uint8)
    all_words = np.empty((n, 2 + len(slots)), np.uint64)
    all_words[:, 0] = all_words[:, 1] = np.asarray(stamps, np.int64)
    all_words[:, 2:] = words.view(np.uint64) if words.dtype == np.float64 else words
    out = np.empty((n, len(template)), np.uint8)
    _pack(out, template, _runs(_TIMES + tuple(RECORD_HEADER + s for s in slots)), all_words.view(np.uint8))
    return out.reshape(-1)


def payload_dtype(payload: bytes, slots: tuple[int, ...]) -> np.dtype:
    """A structured dtype reading a payload's words (``w0``, ``w1``...: uint64) from its bytes."""
    return np.dtype({"names": [f"w{j}" for j in range(len(slots))], "formats": ["<u8"] * len(slots),
                     "offsets": list(slots), "itemsize": len(payload)})
