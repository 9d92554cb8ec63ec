"""An MCAP file written chunk by chunk, readable up to the last chunk if the writer dies.

Schemas and channels go into the data section as they are added, messages into
zstd chunks; a chunk is closed and flushed to the OS when it holds
``chunk_bytes`` or is ``chunk_seconds`` old (wall time), so a process killed
with SIGKILL leaves a file readable up to its last flushed chunk
(:mod:`vilma.record.reader` reads such a file). :meth:`McapFile.close` writes
the summary (schemas, channels, statistics, chunk, metadata and attachment
indexes) and the footer, as the MCAP specification lays out.

Message records are packed in bulk (:meth:`McapFile.write_records`, :mod:`vilma.record.cdr`):
the ``mcap`` package's own writer costs about 10 us a message here, too much
for a compiled run that makes half a million messages a minute of sim time.
"""

from __future__ import annotations

import array
import contextlib
import struct
import time
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.well_known import SchemaEncoding

from vilma import __version__

MAGIC = b"\x89MCAP0\r\n"
MESSAGE_HEADER = struct.Struct("<BQHIQQ")
"""A Message record's opcode, length and fixed fields (31 bytes)."""
_CHUNK = struct.Struct("<BQQQQII4sQ")
"""A Chunk record up to its compressed records: opcode, length, message start and end time, uncompressed size
and CRC, compression (``zstd``), compressed size."""


class RecordError(OSError):
    """The recording cannot go on (unwritable path, full disk): one line saying which file and why."""


@dataclass(frozen=True, slots=True, kw_only=True)
class ChunkPolicy:
    """When a chunk is closed and flushed to the OS."""

    chunk_seconds: float = 1.0
    """Wall time a chunk stays open at most [s]."""
    chunk_bytes: int = 4 << 20
    """Uncompressed size that closes a chunk [bytes]."""
    zstd_level: int = 1
    """zstd level of chunk compression (1: fast)."""


class McapFile:
    """Writes one MCAP file (see the module docstring). Not thread-safe: callers serialise.

    Raises:
        RecordError: the file cannot be created or written (from the constructor and every method).
    """

    def __init__(self, path: Path, policy: ChunkPolicy = ChunkPolicy(), profile: str = "") -> None:
        self.path, self.policy = Path(path), policy
        try:
            self._file = open(self.path, "wb")  # noqa: SIM115 (closed by close())
        except OSError as e:
            raise RecordError(f"cannot record to {path}: {e.strerror or e}") from None
        self._compress = zstandard.ZstdCompressor(level=policy.zstd_level)
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._attachment_indexes: list[AttachmentIndex] = []
        self._counts: dict[int, int] = {}
        self._chunk_count = 0
        self._first = self._last = None
        self._chunk = np.empty(2 * policy.chunk_bytes, np.uint8)
        """The open chunk's records, uncompressed: packed in place (no copy to join them)."""
        self._size = 0
        self._index: dict[int, list[tuple[np.ndarray, np.ndarray]]] = {}
        self._single: dict[int, array.array] = {}
        self._t_lo = self._t_hi = None
        self._opened = time.monotonic()
        self._pos = 0
        self.closed = False
        b = RecordBuilder()
        Header(profile=profile, library=f"vilma {__version__}").write(b)
        self._write(MAGIC + b.end())

    # -- low level ------------------------------------------------------------------------------------------

    def _write(self, data: bytes) -> None:
        try:
            self._file.write(data)
        except OSError as e:
            self._fail(e)
        self._pos += len(data)

    def _fail(self, e: OSError) -> None:
        self.closed = True
        with contextlib.suppress(OSError):
            self._file.close()
        raise RecordError(f"recording to {self.path} stopped: {e.strerror or e}") from None

    def _record(self, rec) -> tuple[int, int]:
        """Write one record in the data section; returns its offset and length."""
        b = RecordBuilder()
        rec.write(b)
        data = b.end()
        at = self._pos
        self._write(data)
        return at, len(data)

    # -- content --------------------------------------------------------------------------------------------

    def add_channel(self, topic: str, schema_name: str, schema: bytes, metadata: dict[str, str] | None = None,
                    encoding: str = "json") -> int:
        """Register a channel of messages in ``encoding`` (``json``: a JSON schema, ``cdr``: a ``ros2msg`` one)
        and its schema, shared by name; returns the channel id."""
        sid = next((s.id for s in self._schemas if s.name == schema_name and s.data == schema), None)
        if sid is None:
            sid = len(self._schemas) + 1
            s = Schema(id=sid, name=schema_name, data=schema,
                       encoding=SchemaEncoding.ROS2 if encoding == "cdr" else SchemaEncoding.JSONSchema)
            self._schemas.append(s)
            self._record(s)
        cid = len(self._channels) + 1
        c = Channel(id=cid, topic=topic, message_encoding=encoding, metadata=metadata or {}, schema_id=sid)
        self._channels.append(c)
        self._counts[cid] = 0
        self._record(c)
        try:
            self._file.flush()  # a file cut short still says what its channels are
        except OSError as e:
            self._fail(e)
        return cid

    def _take(self, size: int) -> np.ndarray:
        """The next ``size`` bytes of the open chunk, to fill."""
        end = self._size + size
        if end > len(self._chunk):
            grown = np.empty(max(end, 2 * len(self._chunk)), np.uint8)
            grown[:self._size] = self._chunk[:self._size]
            self._chunk = grown
        self._size = end
        return self._chunk[end - size:end]

    def _close_if_due(self, close_chunk: bool) -> None:
        if close_chunk and (self._size >= self.policy.chunk_bytes
                            or time.monotonic() - self._opened >= self.policy.chunk_seconds):
            self.flush()

    def write(self, channel: int, stamp_ns: int, data: bytes, close_chunk: bool = True) -> None:
        """One message on ``channel`` at sim time ``stamp_ns`` [ns] (log and publish time).

        ``close_chunk`` False keeps the chunk open whatever its age (for a message that belongs with the next).
        """
        if self.closed:
            return
        entries = self._single.get(channel)
        if entries is None:
            entries = self._single[channel] = array.array("q")
        entries.append(stamp_ns)
        entries.append(self._size)
        record = MESSAGE_HEADER.pack(Opcode.MESSAGE, 22 + len(data), channel, 0, stamp_ns, stamp_ns) + data
        self._take(len(record))[:] = np.frombuffer(record, np.uint8)
        self._counts[channel] += 1
        self._t_lo = stamp_ns if self._t_lo is None or stamp_ns < self._t_lo else self._t_lo
        self._t_hi = stamp_ns if self._t_hi is None or stamp_ns > self._t_hi else self._t_hi
        self._close_if_due(close_chunk)

    def write_records(self, channel: int, stamps: np.ndarray, record_size: int, pack: Callable[[np.ndarray], None],
                      close_chunk: bool = True) -> None:
        """``len(stamps)`` Message records of ``record_size`` bytes on ``channel`` (stamps [ns]), packed in place
        by ``pack`` into the array it is given (:meth:`~vilma.record.schemas.Layout.records`); ``close_chunk`` as
        for :meth:`write`."""
        if not len(stamps) or self.closed:
            return
        start = self._size
        pack(self._take(len(stamps) * record_size))
        self._index.setdefault(channel, []).append((stamps, start + record_size * np.arange(len(stamps))))
        self._counts[channel] += len(stamps)
        lo, hi = int(stamps.min()), int(stamps.max())
        self._t_lo = lo if self._t_lo is None else min(self._t_lo, lo)
        self._t_hi = hi if self._t_hi is None else max(self._t_hi, hi)
        self._close_if_due(close_chunk)

    def tick(self) -> None:
        """Close the chunk if it is ``chunk_seconds`` old: call it now and then when messages may pause."""
        if self._size and time.monotonic() - self._opened >= self.policy.chunk_seconds:
            self.flush()

    def flush(self) -> None:
        """Close the open chunk, write it with its message indexes and hand it to the OS."""
        if self.closed:
            return
        if self._size:
            self._close_chunk()
        try:
            self._file.flush()
        except OSError as e:
            self._fail(e)
        self._opened = time.monotonic()

    def _close_chunk(self) -> None:
        data = self._chunk[:self._size]
        compressed = self._compress.compress(data)  # both release the GIL
        head = _CHUNK.pack(Opcode.CHUNK, _CHUNK.size - 9 + len(compressed), self._t_lo, self._t_hi, self._size,
                           zlib.crc32(data), 4, b"zstd", len(compressed))
        at, length = self._pos, len(head) + len(compressed)
        self._write(head)
        self._write(compressed)
        index_at = self._pos
        for c, entries in self._single.items():  # messages written one by one
            pairs = np.frombuffer(entries, np.int64).reshape(-1, 2)
            self._index.setdefault(c, []).append((pairs[:, 0], pairs[:, 1]))
        offsets, blob = {}, []
        for c, parts in sorted(self._index.items()):
            entries = np.empty((sum(len(p[0]) for p in parts), 2), "<u8")
            entries[:, 0] = np.concatenate([p[0] for p in parts])
            entries[:, 1] = np.concatenate([p[1] for p in parts])
            if (np.diff(entries[:, 0].view(np.int64)) < 0).any():  # by log time, then offset
                entries = entries[np.lexsort((entries[:, 1], entries[:, 0]))]
            body = entries.tobytes()
            offsets[c] = index_at + sum(map(len, blob))
            blob.append(struct.pack("<BQHI", Opcode.MESSAGE_INDEX, 6 + len(body), c, len(body)) + body)
        index = b"".join(blob)
        self._write(index)
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=self._t_lo, message_end_time=self._t_hi, chunk_start_offset=at, chunk_length=length,
            message_index_offsets=offsets, message_index_length=len(index), compression="zstd",
            compressed_size=len(compressed), uncompressed_size=self._size))
        self._first = self._t_lo if self._first is None else min(self._first, self._t_lo)
        self._last = self._t_hi if self._last is None else max(self._last, self._t_hi)
        self._chunk_count += 1
        self._size, self._index, self._t_lo, self._t_hi = 0, {}, None, None
        self._single = {}

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """A metadata record (string keys and values), written at once."""
        if self.closed:
            return
        at, length = self._record(Metadata(name=name, metadata=data))
        self._metadata_indexes.append(MetadataIndex(offset=at, length=length, name=name))
        self.flush()

    def add_attachment(self, name: str, media_type: str, data: bytes, log_time: int = 0) -> None:
        """An attachment (a file kept in the recording), written at once; ``log_time`` in sim time [ns]."""
        if self.closed:
            return
        at, length = self._record(Attachment(create_time=time.time_ns(), log_time=log_time, name=name,
                                             media_type=media_type, data=data))
        self._attachment_indexes.append(AttachmentIndex(offset=at, length=length, log_time=log_time,
                                                        create_time=0, data_size=len(data), name=name,
                                                        media_type=media_type))
        self.flush()

    @property
    def message_count(self) -> int:
        """Messages written so far (in closed chunks and the open one)."""
        return sum(self._counts.values())

    def close(self) -> None:
        """Write the last chunk, the summary and the footer, and close the file (a second call does nothing)."""
        if self.closed:
            return
        if self._size:
            self._close_chunk()
        self._record(DataEnd(data_section_crc=0))
        start = self._pos
        b = RecordBuilder()
        groups = []
        for opcode, records in ((Opcode.SCHEMA, self._schemas), (Opcode.CHANNEL, self._channels),
                                (Opcode.STATISTICS, [self._statistics()]),
                                (Opcode.CHUNK_INDEX, self._chunk_indexes),
                                (Opcode.ATTACHMENT_INDEX, self._attachment_indexes),
                                (Opcode.METADATA_INDEX, self._metadata_indexes)):
            if records:
                g = b.count
                for r in records:
                    r.write(b)
                groups.append(SummaryOffset(group_opcode=opcode, group_start=start + g, group_length=b.count - g))
        offsets_at = start + b.count
        for g in groups:
            g.write(b)
        summary = b.end()
        # The summary CRC covers the summary and summary offset sections and the footer up to the CRC itself
        # (MCAP specification, Footer), as the mcap package's own writer computes it.
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 20, start, offsets_at), zlib.crc32(summary))
        Footer(summary_start=start, summary_offset_start=offsets_at, summary_crc=crc).write(b)
        self._write(summary + b.end() + MAGIC)
        try:
            self._file.close()
        except OSError as e:
            self._fail(e)
        self.closed = True

    def _statistics(self) -> Statistics:
        return Statistics(attachment_count=len(self._attachment_indexes), channel_count=len(self._channels),
                          channel_message_counts=dict(self._counts), chunk_count=self._chunk_count,
                          message_count=self.message_count, message_start_time=self._first or 0,
                          message_end_time=self._last or 0, metadata_count=len(self._metadata_indexes),
                          schema_count=len(self._schemas))
