"""Reading a vilma recording back: messages as vilma types, readings as arrays, metadata and attachments.

:func:`read_recording` reads the file from the start, record by record, so a
file whose writer was killed (no summary, a torn last record) is read up to
its last complete chunk; :attr:`Recording.complete` says whether the footer
was there. A reset of the simulator starts its clock again from 0: each message
gets the epoch it was stamped in (:class:`Epochs`), and a topic comes back in
epoch order, then stamp order. Camera images and laser scans come back as
:class:`~vilma.core.messages.Image` and :class:`~vilma.core.messages.PointCloud`
(a JPEG image as its decoded pixels: see :mod:`vilma.record.world_cdr`), from ROS 2 types (a laser scan from a
LaserScan and its points beside, or from a multi-layer laser's PointCloud2) or, in older recordings, Foxglove's
JSON ones.
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass, field
from pathlib import Path

import msgspec
import numpy as np
import zstandard
from mcap.exceptions import InvalidMagic, McapError
from mcap.records import Attachment, Channel, Footer, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

from vilma.bus.topics import SENSOR_TOPICS, TOPICS
from vilma.core import messages as m
from vilma.record.mcap_file import MAGIC
from vilma.record.schemas import DRIVE_LOG, Layout, channels, decode_fields, numeric_layouts, vilma_layouts
from vilma.record.world_cdr import decode_world, is_world, points_of
from vilma.scenario.drive_log import COLUMNS
from vilma.sensors import Readings


class RecordingError(ValueError):
    """A file that is not a readable MCAP recording: one line saying which and why."""


@dataclass
class Recording:
    """What a recording holds. Topics are named within the car (``pose``, ``driver/status``, ``drive_log``)."""

    path: Path
    car: str = "vilma"
    schemas: dict[str, str] = field(default_factory=dict)
    """Topic -> schema name."""
    encodings: dict[str, str] = field(default_factory=dict)
    """Topic -> message encoding (``cdr``: numeric topics, ``json``: the others)."""
    raw: dict[str, tuple[list[int], list[bytes]]] = field(default_factory=dict)
    """Topic -> (log times [ns], payloads), in file order."""
    epochs: dict[str, list[int]] = field(default_factory=dict)
    """Topic -> the epoch of each message of ``raw`` (0, and one more after each reset of the sim's clock)."""
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    attachments: dict[str, bytes] = field(default_factory=dict)
    complete: bool = False
    """Whether the file ended with its summary and footer (False: cut short, read up to the last chunk)."""

    @property
    def topics(self) -> list[str]:
        """Topics with at least one message."""
        return [t for t, (st, _) in self.raw.items() if st]

    @property
    def world_topics(self) -> list[str]:
        """Topics of camera images and laser scans with at least one message."""
        return [t for t in self.topics if is_world(t, self.schemas.get(t, "")) and t not in TOPICS]

    def count(self, name: str) -> int:
        """Messages on topic ``name``."""
        return len(self.raw.get(name, ((), ()))[0])

    def payloads(self, name: str) -> list[bytes]:
        """The payloads of topic ``name``, in epoch then stamp order."""
        st, data = self.raw.get(name, ([], []))
        return [data[i] for i in self._order(name, np.asarray(st, np.int64)).tolist()]

    def _order(self, name: str, stamps: np.ndarray) -> np.ndarray:
        return np.lexsort((stamps, np.asarray(self.epochs.get(name, []), np.int64)))

    def epoch(self, name: str) -> np.ndarray:
        """The epoch of each message of topic ``name``, in the order the other methods give them."""
        return np.sort(np.asarray(self.epochs.get(name, []), np.int64))

    def world_payloads(self, name: str) -> tuple[list[int], list[tuple[bytes, ...]]]:
        """Log times [ns] and payloads of world topic ``name`` in file order, each with the payload beside it
        that decoding needs too (``laser/points`` beside a LaserScan).

        Raises:
            RecordingError: the topic beside is missing or does not match message for message.
        """
        st, data = self.raw.get(name, ([], []))
        beside = points_of(self.schemas.get(name, ""))
        if beside is None:
            return st, [(p,) for p in data]
        st_beside, data_beside = self.raw.get(beside, ([], []))
        if st_beside != st:
            raise RecordingError(f"{self.path}: topic {beside} does not match {name} message for message")
        return st, list(zip(data, data_beside, strict=True))

    def objects(self, name: str) -> list[dict]:
        """The JSON objects of topic ``name``, in epoch then stamp order."""
        data = self.payloads(name)
        return msgspec.json.decode(b"[" + b",".join(data) + b"]") if data else []

    def readings(self, name: str) -> Readings:
        """A sensor topic as arrays (epoch then stamp order).

        Raises:
            RecordingError: the topic is of a type this vilma does not read.
        """
        cls = SENSOR_TOPICS[name]
        return _arrays(self, name, cls.__struct_fields__[1:], cls)

    def drive_log(self) -> np.ndarray:
        """The runner's rows (:data:`~vilma.scenario.drive_log.COLUMNS`), shape (n, len(COLUMNS)); empty if none."""
        return _arrays(self, DRIVE_LOG, COLUMNS, m.Message).values

    def messages(self, name: str) -> list[m.Message]:
        """Topic ``name`` as vilma messages, in epoch then stamp order."""
        if name in SENSOR_TOPICS:
            return self.readings(name).messages()
        if name not in TOPICS and is_world(name, self.schemas.get(name, "")):
            st, payloads = self.world_payloads(name)
            return [decode_world(self.schemas[name], *payloads[i])
                    for i in self._order(name, np.asarray(st, np.int64)).tolist()]
        cls = TOPICS[name]
        return [decode_fields(cls, o) for o in self.objects(name)]

    def meta(self, name: str) -> dict:
        """Metadata record ``name`` with its JSON values decoded (empty if absent)."""
        out = {}
        for k, v in self.metadata.get(name, {}).items():
            try:
                out[k] = json.loads(v)
            except ValueError:
                out[k] = v
        return out


def _arrays(rec: Recording, name: str, fields: tuple[str, ...], cls: type[m.Message]) -> Readings:
    data = rec.raw.get(name, ([], []))[1]
    if rec.encodings.get(name, "json") == "json":  # a recording of vilma 0.1, before CDR
        stamps, values = _json_arrays(data, fields)
    else:
        stamps, columns = None, {}
        for part, lay in _parts(rec, name):
            try:
                st, floats = lay.decode(rec.raw.get(part, ([], []))[1])
            except ValueError as e:
                raise RecordingError(f"{rec.path}: topic {part}: {e}") from None
            if stamps is not None and not np.array_equal(st, stamps):
                raise RecordingError(f"{rec.path}: topic {part} does not match {name} message for message")
            stamps = st
            columns.update((f, floats[:, j]) for j, f in enumerate(lay.fields) if f is not None)
        values = np.stack([columns[f] for f in fields], axis=1) if fields else np.empty((len(stamps), 0))
    order = rec._order(name, stamps)
    return Readings(name, cls, stamps[order], values[order])


def _parts(rec: Recording, name: str) -> list[tuple[str, Layout]]:
    """The topics (and their layouts) ``name``'s values are read from: itself in a vilma type (a recording made
    before the standard types), else itself and the topics beside it that carry some of its fields."""
    schema = rec.schemas[name]
    old = vilma_layouts().get(name)
    if old is not None and schema == old.schema_name:
        return [(name, old)]
    layouts = numeric_layouts(rec.car)
    lay = layouts.get(name)
    if lay is None or lay.schema_name != schema:
        raise RecordingError(f"{rec.path}: topic {name} is {schema}, which this vilma does not read")
    parts = [(c, layouts[c]) for c in channels(name) if any(f is not None for f in layouts[c].fields)]
    for c, lay in parts[1:]:
        if rec.schemas.get(c) != lay.schema_name:
            raise RecordingError(f"{rec.path}: topic {name} needs topic {c} ({lay.schema_name}) beside it, "
                                 f"which the file lacks")
    return parts


def _json_arrays(data: list[bytes], fields: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Stamps and values of JSON objects with ``stamp_ns`` and ``fields``; NaN where a value is null."""
    row = msgspec.defstruct("Row", [("stamp_ns", int), *((f, float | None, None) for f in fields)])
    rows = msgspec.json.decode(b"[" + b",".join(data) + b"]", type=list[row]) if data else []
    values = np.array([msgspec.structs.astuple(r)[1:] for r in rows], dtype=float).reshape(len(rows), len(fields))
    return np.array([r.stamp_ns for r in rows], np.int64), values


class Epochs:
    """Which epoch of the sim's clock each message was stamped in, told from the stamps in file order.

    The simulator's reset sets its clock back to 0, so a topic whose stamp goes back has crossed a reset: the
    first to cross starts the next epoch. A message of a topic last heard before the newest epoch began is of
    the latest epoch since (after its own, if its stamp went back) whose end it is nearer than the newest
    epoch's time (a late one from another process, stamped near the end of its epoch), else of the newest (its
    topic fell silent before a reset and spoke again after).
    """

    def __init__(self) -> None:
        self.ends: list[int] = [0]
        """The latest stamp of each epoch so far [ns]."""
        self._topics: dict[str, tuple[int, int]] = {}  # topic -> (epoch, last stamp)

    def of(self, name: str, t: int) -> int:
        """The epoch of the next message of topic ``name``, stamped ``t`` [ns]."""
        now = len(self.ends) - 1
        e, last = self._topics.get(name, (0, t))
        if t < last and e == now:  # the first to cross a reset
            e = now + 1
        elif e < now:  # last heard before a reset: in which epoch since?
            first = e + 1 if t < last else e
            e = next((k for k in range(now - 1, first - 1, -1) if 0 <= self.ends[k] - t < abs(t - self.ends[now])),
                     now)
        if e == len(self.ends):
            self.ends.append(t)
        self.ends[e] = max(self.ends[e], t)
        self._topics[name] = (e, t)
        return e


def read_recording(path: Path) -> Recording:
    """Read ``path`` (see the module docstring).

    Raises:
        RecordingError: not an MCAP file, or not readable at all.
    """
    path = Path(path)
    rec = Recording(path)
    try:
        f = path.open("rb")
    except OSError as e:
        raise RecordingError(f"{path}: cannot read: {e.strerror or e}") from None
    schemas: dict[int, Schema] = {}
    channels: dict[int, str] = {}
    prefix: str | None = None
    epochs = Epochs()
    with f:
        try:
            for r in StreamReader(f, record_size_limit=1 << 31).records:
                if isinstance(r, Message):
                    name = channels.get(r.channel_id)
                    if name is not None:
                        st, data = rec.raw[name]
                        st.append(r.log_time)
                        data.append(r.data)
                        rec.epochs[name].append(epochs.of(name, r.log_time))
                elif isinstance(r, Schema):
                    schemas[r.id] = r
                elif isinstance(r, Channel):
                    if prefix is None and r.topic.startswith("vilma/") and r.topic.count("/") >= 2:
                        rec.car = r.topic.split("/")[1]
                        prefix = f"vilma/{rec.car}/"
                    name = r.topic[len(prefix):] if prefix and r.topic.startswith(prefix) else r.topic
                    if r.id not in channels:
                        channels[r.id] = name
                        rec.raw.setdefault(name, ([], []))
                        rec.epochs.setdefault(name, [])
                        rec.schemas[name] = schemas[r.schema_id].name if r.schema_id in schemas else ""
                        rec.encodings[name] = r.message_encoding
                elif isinstance(r, Metadata):
                    rec.metadata[r.name] = dict(r.metadata)
                elif isinstance(r, Attachment):
                    rec.attachments[r.name] = r.data
                elif isinstance(r, Footer):
                    rec.complete = True
        except (McapError, struct.error, zstandard.ZstdError, ValueError, EOFError) as e:
            if isinstance(e, InvalidMagic) or f.tell() < len(MAGIC):
                raise RecordingError(f"{path}: not a readable MCAP recording ({type(e).__name__}: {e})") from None
    return rec
