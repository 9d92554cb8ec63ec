"""How each topic is written in a recording: channel, schema and bytes, packed in bulk from arrays.

Numeric topics are ROS 2 messages (``ros2msg`` schemas, CDR payloads, as
``ros2 bag`` writes them), which Foxglove, Lichtblick, PlotJuggler and ROS 2
tools decode from the file alone:

- every sensor topic and ``drive_log`` (the runner's row a control period):
  ``vilma_msgs/msg/<Type>``, a ``builtin_interfaces/Time stamp`` (sim time)
  and the message's float64 fields, unit in a comment: read back exactly
  (NaN and infinities included);
- for Foxglove's panels, derived as they are written: ``tf``
  (``foxglove_msgs/msg/FrameTransform`` ``map`` -> ``<car>``, from ``pose``)
  and ``gps/fix`` (``foxglove_msgs/msg/LocationFix``, from ``gps``).

Every numeric message has a fixed size, so a column of them is packed in one
compiled loop (:mod:`vilma.record.cdr`). Messages that are not only numbers
(orders, statuses) are JSON objects with a ``vilma.<Type>`` JSON schema.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import msgspec
import numpy as np

from vilma.bus.topics import SENSOR_TOPICS
from vilma.core import messages as m
from vilma.core.geometry import quaternion_from_euler
from vilma.record.cdr import RECORD_HEADER, CdrBody, pack_records, payload_dtype, stamps_of
from vilma.scenario.drive_log import COLUMNS

_enc = msgspec.json.Encoder()

_UNITS = {
    "x": "m", "y": "m", "z": "m", "roll": "rad", "pitch": "rad", "yaw": "rad", "vx": "m/s", "vy": "m/s",
    "vz": "m/s", "vx_world": "m/s", "vy_world": "m/s", "vz_world": "m/s", "wx": "rad/s", "wy": "rad/s",
    "wz": "rad/s", "ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2", "latitude": "deg", "longitude": "deg",
    "altitude": "m", "fl": "rad/s", "fr": "rad/s", "rl": "rad/s", "rr": "rad/s", "speed": "m/s",
    "yaw_rate": "rad/s", "steer": "rad", "drive_force": "N", "brake_force": "N", "t": "s",
    "target_speed": "m/s", "measured_speed": "m/s", "est_x": "m", "est_y": "m", "est_yaw": "rad",
    "cmd_steer": "rad", "controller_us": "us",  # cmd_drive, cmd_brake: in the command's own unit
}
DRIVE_LOG = "drive_log"
"""The runner's topic: one :data:`~vilma.scenario.drive_log.COLUMNS` row a control period (true plant + driver)."""
TF = "tf"
"""The car's frame in the map (``foxglove_msgs/msg/FrameTransform``), derived from ``pose``."""
FIX = "gps/fix"
"""The GPS fix as Foxglove's map draws it (``foxglove_msgs/msg/LocationFix``), derived from ``gps``."""
DERIVED = {"pose": TF, "gps": FIX}
"""Topic -> the topic derived from each of its messages."""

_SEPARATOR = "=" * 80
_TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec"
_VECTOR3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z"
_QUATERNION = "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1"


def ros2msg(definition: str, *dependencies: str) -> bytes:
    """A ``ros2msg`` schema: the message's definition, then each type it uses (``MSG: pkg/Type`` and its own)."""
    return "\n".join([definition, *(f"{_SEPARATOR}\n{d}" for d in dependencies)]).encode() + b"\n"


@dataclass(frozen=True, slots=True)
class Layout:
    """How one numeric topic is written: its ROS 2 type and the CDR payload, a template with slots.

    ``floats`` makes a derived topic's (n, len(slots) - 1) float64s from its source's values (n, k); a vilma type
    (``floats`` None) writes the values as they are: the message's fields after ``stamp_ns``, in order, which
    ``fields`` names (none for a derived topic).
    """

    schema_name: str
    schema: bytes
    payload: bytes
    slots: tuple[int, ...]
    fields: tuple[str, ...]
    floats: Callable[[np.ndarray], np.ndarray] | None = None

    def __post_init__(self) -> None:
        if any(b - a != 8 for a, b in zip(self.slots[1:], self.slots[2:], strict=False)):
            raise ValueError(f"{self.schema_name}: the float64 slots must be side by side")

    def records(self, stamps: np.ndarray, values: np.ndarray, channel: int, out: np.ndarray | None = None
                ) -> np.ndarray:
        """The MCAP Message records of the rows on ``channel`` (bytes as uint8, each of :attr:`record_size`; in
        ``out`` if given)."""
        floats = values if self.floats is None else self.floats(values)
        return pack_records(self.payload, self.slots, channel, stamps, floats, out)

    @property
    def record_size(self) -> int:
        """Bytes of one Message record."""
        return RECORD_HEADER + len(self.payload)

    def encode(self, stamps: np.ndarray, values: np.ndarray) -> list[bytes]:
        """One CDR payload per row."""
        blob = self.records(stamps, values, 0).tobytes()
        size = self.record_size
        return [blob[i + RECORD_HEADER:i + size] for i in range(0, len(blob), size)]

    def encode_one(self, stamp_ns: int, values: list[float]) -> bytes:
        """The payload of one message (fields after ``stamp_ns``), as :meth:`encode` writes it (without numpy
        for a vilma type: a live program's path, message by message)."""
        row = values if self.floats is None else self.floats(np.array([values], np.float64))[0].tolist()
        out = bytearray(self.payload)
        struct.pack_into("<iI", out, self.slots[0], *divmod(stamp_ns, 1_000_000_000))
        struct.pack_into(f"<{len(row)}d", out, self.slots[1], *row)  # the float64 slots are side by side
        return bytes(out)

    def decode(self, payloads: list[bytes]) -> tuple[np.ndarray, np.ndarray]:
        """Stamps [ns] and values (n, len(fields)) of payloads this layout wrote.

        Raises:
            ValueError: a payload of another size (another type, or a file written otherwise).
        """
        size = len(self.payload)
        bad = next((len(p) for p in payloads if len(p) != size), None)
        if bad is not None:
            raise ValueError(f"a {self.schema_name} message of {bad} bytes, not {size}")
        rows = np.frombuffer(b"".join(payloads), payload_dtype(self.payload, self.slots))
        return stamps_of(rows["sec"], rows["nanosec"]), rows["values"].astype(np.float64).reshape(len(rows), -1)


def _vilma_layout(type_name: str, doc: str, fields: tuple[str, ...]) -> Layout:
    lines = [f"# {doc}", "builtin_interfaces/Time stamp  # sim time",
             *(f"float64 {f}" + (f"  # [{_UNITS[f]}]" if f in _UNITS else "") for f in fields)]
    payload, slots = CdrBody().time().float64(len(fields)).payload()
    return Layout(f"vilma_msgs/msg/{type_name}", ros2msg("\n".join(lines), _TIME), payload, slots, fields)


def _tf_layout(car: str) -> Layout:
    definition = ("builtin_interfaces/Time timestamp\nstring parent_frame_id\nstring child_frame_id\n"
                  "geometry_msgs/Vector3 translation\ngeometry_msgs/Quaternion rotation")
    payload, slots = CdrBody().time().string("map").string(car).float64(7).payload()

    def floats(v):
        return np.column_stack([v[:, :3], *quaternion_from_euler(v[:, 3], v[:, 4], v[:, 5])])
    return Layout("foxglove_msgs/msg/FrameTransform", ros2msg(definition, _TIME, _VECTOR3, _QUATERNION),
                  payload, slots, (), floats)


def _fix_layout() -> Layout:
    definition = ("builtin_interfaces/Time timestamp\nstring frame_id\nfloat64 latitude\nfloat64 longitude\n"
                  "float64 altitude\nfloat64[9] position_covariance\nuint8 UNKNOWN=0\nuint8 APPROXIMATED=1\n"
                  "uint8 DIAGONAL_KNOWN=2\nuint8 KNOWN=3\nuint8 position_covariance_type")
    payload, slots = CdrBody().time().string("gps").float64(3).zeros(9, 8).zeros(1, 1).payload()

    return Layout("foxglove_msgs/msg/LocationFix", ros2msg(definition, _TIME), payload, slots, (),
                  lambda v: v[:, :3])


def numeric_layouts(car: str) -> dict[str, Layout]:
    """Topic name (within the car) -> layout, for every topic made of numbers (and the derived ones)."""
    out = {name: _vilma_layout(cls.__name__, (cls.__doc__ or "").split("\n")[0], cls.__struct_fields__[1:])
           for name, cls in SENSOR_TOPICS.items()}
    out[DRIVE_LOG] = _vilma_layout("DriveLogRow", "The runner's row a control period: the true plant and the "
                                   "driver (t is sim time [s]).", COLUMNS)
    out[TF], out[FIX] = _tf_layout(car), _fix_layout()
    return out


# -- messages that are not only numbers (live recordings), and the JSON schemas' pieces ---------------------------

TIMESTAMP = {"type": "object", "title": "foxglove.Time", "properties": {
    "sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}}
VECTOR3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
QUATERNION = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}


def object_schema(title: str, description: str, props: dict, required: list[str]) -> bytes:
    """A JSON schema (draft 2020-12) of an object titled ``title`` with ``props``."""
    return json.dumps({"$schema": "https://json-schema.org/draft/2020-12/schema", "title": title,
                       "description": description, "type": "object", "properties": props,
                       "required": required}).encode()


_JSON_TYPES = {float: "number", int: "integer", bool: "boolean", str: "string"}


def struct_schema(cls: type[m.Message]) -> bytes:
    """The JSON schema ``vilma.<Type>`` of a message written field by field (see :func:`encode_struct`)."""
    props = {"stamp_ns": {"type": "integer", "description": "sim time [ns]"}, "timestamp": TIMESTAMP}
    for f in msgspec.structs.fields(cls)[1:]:
        kind = _JSON_TYPES.get(f.type, "string" if isinstance(f.type, type) and issubclass(f.type, str) else None)
        props[f.name] = {"type": [kind, "null"]} if kind == "number" else ({"type": kind} if kind else {})
    return object_schema(f"vilma.{cls.__name__}", (cls.__doc__ or "").split("\n")[0], props, ["stamp_ns"])


def encode_struct(msg: m.Message) -> bytes:
    """A message as one JSON object with its fields by name (and a Foxglove ``timestamp``)."""
    d = msgspec.structs.asdict(msg)
    t = msg.stamp_ns
    return _enc.encode({"timestamp": {"sec": t // 1_000_000_000, "nsec": t % 1_000_000_000}, **d})


def decode_fields(cls: type[m.Message], obj: dict) -> m.Message:
    """The message ``cls`` from its JSON object (vilma's fields; null floats back to NaN or the default)."""
    kw = {}
    for f in msgspec.structs.fields(cls):
        v = obj.get(f.name)
        if v is None and f.type is float:
            d = f.default
            v = d if isinstance(d, float) and math.isinf(d) else math.nan
        elif v is not None and isinstance(f.type, type) and issubclass(f.type, Enum):
            v = f.type(v)
        if v is not None:
            kw[f.name] = v
    return cls(**kw)
