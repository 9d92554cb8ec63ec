"""How each topic is written in a recording: channel, schema and JSON, encoded in bulk from arrays.

Every message is one JSON object stamped with sim time. Topics that Foxglove
can draw use its well-known schema names and carry vilma's own fields beside
the well-known ones (JSON readers ignore fields they do not know), so one
channel is both drawn by Foxglove and read back exactly by vilma:

- ``pose``: ``foxglove.PoseInFrame`` (frame ``map``) plus ``stamp_ns, x, y, z, roll, pitch, yaw``;
- ``gps``: ``foxglove.LocationFix`` plus ``stamp_ns, x, y, z`` (local ENU [m]);
- ``tf`` (derived from ``pose``): ``foxglove.FrameTransform`` ``map`` -> ``<car>``;
- the other sensors and ``drive_log`` (the runner's row a control period): ``vilma.<Type>`` JSON schemas
  with every field named, unit in its description.

Floats are written in their shortest exact form, so what is read back equals what was logged; NaN
is written as ``null`` (read back as NaN, or infinity where the field's default is infinite).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

import msgspec
import numpy as np

from vilma.bus.topics import SENSOR_TOPICS
from vilma.core import messages as m
from vilma.core.geometry import quaternion_from_euler
from vilma.record.jsonpack import message_records
from vilma.scenario.drive_log import COLUMNS

_enc = msgspec.json.Encoder()

TIMESTAMP = {"type": "object", "title": "foxglove.Time", "properties": {
    "sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}}
VECTOR3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
QUATERNION = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}

_UNITS = {
    "x": "m", "y": "m", "z": "m", "roll": "rad", "pitch": "rad", "yaw": "rad", "vx": "m/s", "vy": "m/s",
    "vz": "m/s", "vx_world": "m/s", "vy_world": "m/s", "vz_world": "m/s", "wx": "rad/s", "wy": "rad/s",
    "wz": "rad/s", "ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2", "latitude": "deg", "longitude": "deg",
    "altitude": "m", "fl": "rad/s", "fr": "rad/s", "rl": "rad/s", "rr": "rad/s", "speed": "m/s",
    "yaw_rate": "rad/s", "steer": "rad", "drive_force": "N", "brake_force": "N", "t": "s",
    "target_speed": "m/s", "measured_speed": "m/s", "est_x": "m", "est_y": "m", "est_yaw": "rad",
    "cmd_steer": "rad", "controller_us": "us",
}
DRIVE_LOG = "drive_log"
"""The runner's topic: one :data:`~vilma.scenario.drive_log.COLUMNS` row a control period (true plant + driver)."""
TF = "tf"
"""The car's frame in the map (``foxglove.FrameTransform``), derived from ``pose``."""


def _number(name: str) -> dict:
    unit = _UNITS.get(name)
    return {"type": "number", **({"description": f"[{unit}]"} if unit else {})}


def object_schema(title: str, description: str, props: dict, required: list[str]) -> bytes:
    """A JSON schema (draft 2020-12) of an object titled ``title`` with ``props``."""
    return json.dumps({"$schema": "https://json-schema.org/draft/2020-12/schema", "title": title,
                       "description": description, "type": "object", "properties": props,
                       "required": required}).encode()


@dataclass(frozen=True, slots=True)
class Layout:
    """How one numeric topic is written: schema name and JSON schema, and the JSON of a row.

    ``template`` is the JSON object with a ``%b`` per column that :attr:`columns` makes from
    ``(stamps [ns], values (n, k))`` (the message's fields after ``stamp_ns``, in order);
    ``fields`` names the vilma fields read back.
    """

    schema_name: str
    schema: bytes
    template: bytes
    columns: Callable[[np.ndarray, np.ndarray], list[tuple[str, np.ndarray]]]
    fields: tuple[str, ...]
    row: Callable[[int, list[float]], list]
    """The same values as :attr:`columns` for one message (plain Python: the live path, no numpy)."""

    def records(self, stamps: np.ndarray, values: np.ndarray, channel: int) -> tuple[bytes, np.ndarray]:
        """MCAP Message records of the rows on ``channel`` (bytes, and each record's offset in them)."""
        stamps = np.asarray(stamps, dtype=np.int64)
        return message_records(self.template, self.columns(stamps, values), channel, stamps)

    def encode(self, stamps: np.ndarray, values: np.ndarray) -> list[bytes]:
        """One JSON payload per row."""
        if not len(stamps):
            return []
        blob, starts = self.records(stamps, values, 0)
        ends = [*starts[1:].tolist(), len(blob)]
        return [blob[a + 31:b] for a, b in zip(starts.tolist(), ends, strict=True)]

    def encode_one(self, stamp_ns: int, values: list[float]) -> bytes:
        """The JSON of one message (fields after ``stamp_ns``), as :meth:`encode` writes it."""
        return self.template % tuple(_enc.encode(self.row(stamp_ns, values))[1:-1].split(b","))


def _time_columns(stamps: np.ndarray) -> list[tuple[str, np.ndarray]]:
    return [("i", stamps // 1_000_000_000), ("i", stamps % 1_000_000_000)]


def _quat(roll: float, pitch: float, yaw: float) -> list[float]:
    """:func:`~vilma.core.geometry.quaternion_from_euler` for one angle triple, in plain Python."""
    cr, sr = math.cos(roll * 0.5), math.sin(roll * 0.5)
    cp, sp = math.cos(pitch * 0.5), math.sin(pitch * 0.5)
    cy, sy = math.cos(yaw * 0.5), math.sin(yaw * 0.5)
    return [sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy]


def _own(fields: tuple[str, ...]) -> bytes:
    return b"".join(b',"%s":%%b' % f.encode() for f in fields)


def _plain_layout(name: str, doc: str, fields: tuple[str, ...]) -> Layout:
    props = {"stamp_ns": {"type": "integer", "description": "sim time [ns]"}, "timestamp": TIMESTAMP,
             **{f: _number(f) for f in fields}}
    template = b'{"timestamp":{"sec":%b,"nsec":%b},"stamp_ns":%b' + _own(fields) + b"}"

    def columns(st, v):
        return [*_time_columns(st), ("i", st), *(("f", v[:, i]) for i in range(len(fields)))]

    def row(t, v):
        return [t // 1_000_000_000, t % 1_000_000_000, t, *v]
    return Layout(name, object_schema(name, doc, props, ["stamp_ns", *fields]), template, columns, fields, row)


def _message_layout(cls: type[m.Message]) -> Layout:
    fields = cls.__struct_fields__[1:]
    return _plain_layout(f"vilma.{cls.__name__}", (cls.__doc__ or "").split("\n")[0], fields)


def _pose_layout() -> Layout:
    fields = m.Pose.__struct_fields__[1:]
    props = {"timestamp": TIMESTAMP, "frame_id": {"type": "string"},
             "pose": {"type": "object", "properties": {"position": VECTOR3, "orientation": QUATERNION}},
             "stamp_ns": {"type": "integer", "description": "sim time [ns]"}, **{f: _number(f) for f in fields}}
    template = (b'{"timestamp":{"sec":%b,"nsec":%b},"frame_id":"map","pose":{"position":{"x":%b,"y":%b,"z":%b},'
                b'"orientation":{"x":%b,"y":%b,"z":%b,"w":%b}},"stamp_ns":%b' + _own(fields) + b"}")

    def columns(st, v):
        q = quaternion_from_euler(v[:, 3], v[:, 4], v[:, 5])
        return [*_time_columns(st), *(("f", v[:, i]) for i in range(3)), *(("f", c) for c in q), ("i", st),
                *(("f", v[:, i]) for i in range(6))]

    def row(t, v):
        return [t // 1_000_000_000, t % 1_000_000_000, *v[:3], *_quat(*v[3:6]), t, *v]
    doc = "The car's ground-truth pose in the map (ENU); vilma's fields beside the well-known ones."
    return Layout("foxglove.PoseInFrame", object_schema("foxglove.PoseInFrame", doc, props, ["timestamp", "pose"]),
                  template, columns, fields, row)


def _tf_layout(car: str) -> Layout:
    props = {"timestamp": TIMESTAMP, "parent_frame_id": {"type": "string"}, "child_frame_id": {"type": "string"},
             "translation": VECTOR3, "rotation": QUATERNION}
    template = (b'{"timestamp":{"sec":%b,"nsec":%b},"parent_frame_id":"map","child_frame_id":"'
                + car.encode() + b'","translation":{"x":%b,"y":%b,"z":%b},"rotation":{"x":%b,"y":%b,"z":%b,"w":%b}}')

    def columns(st, v):
        q = quaternion_from_euler(v[:, 3], v[:, 4], v[:, 5])
        return [*_time_columns(st), *(("f", v[:, i]) for i in range(3)), *(("f", c) for c in q)]

    def row(t, v):
        return [t // 1_000_000_000, t % 1_000_000_000, *v[:3], *_quat(*v[3:6])]
    doc = f"The frame of car {car} in the map, from its pose."
    return Layout("foxglove.FrameTransform", object_schema("foxglove.FrameTransform", doc, props,
                                                     ["timestamp", "parent_frame_id", "child_frame_id"]),
                  template, columns, (), row)


def _gps_layout() -> Layout:
    fields = m.GpsFix.__struct_fields__[1:]
    own = fields[3:]
    props = {"timestamp": TIMESTAMP, "frame_id": {"type": "string"}, "latitude": _number("latitude"),
             "longitude": _number("longitude"), "altitude": _number("altitude"),
             "position_covariance": {"type": "array", "items": {"type": "number"}, "minItems": 9, "maxItems": 9},
             "position_covariance_type": {"type": "integer", "description": "0 unknown, 1 approximated, "
                                          "2 diagonal known, 3 known"},
             "stamp_ns": {"type": "integer", "description": "sim time [ns]"}, **{f: _number(f) for f in own}}
    template = (b'{"timestamp":{"sec":%b,"nsec":%b},"frame_id":"gps","latitude":%b,"longitude":%b,"altitude":%b,'
                b'"position_covariance":[0,0,0,0,0,0,0,0,0],"position_covariance_type":0,"stamp_ns":%b'
                + _own(own) + b"}")

    def columns(st, v):
        return [*_time_columns(st), *(("f", v[:, i]) for i in range(3)), ("i", st),
                *(("f", v[:, i]) for i in range(3, 6))]

    def row(t, v):
        return [t // 1_000_000_000, t % 1_000_000_000, *v[:3], t, *v[3:6]]
    doc = "GPS fix: WGS84 latitude, longitude [deg], altitude [m]; local ENU x, y, z [m] beside."
    return Layout("foxglove.LocationFix", object_schema("foxglove.LocationFix", doc, props,
                                                  ["latitude", "longitude", "altitude"]), template, columns, fields,
                  row)


def numeric_layouts(car: str) -> dict[str, Layout]:
    """Topic name (within the car) -> layout, for every topic made of numbers."""
    out = {name: _message_layout(cls) for name, cls in SENSOR_TOPICS.items()}
    out["pose"], out["gps"], out[TF] = _pose_layout(), _gps_layout(), _tf_layout(car)
    out[DRIVE_LOG] = _plain_layout("vilma.DriveLogRow", "The runner's row a control period: the true plant "
                                   "and the driver (t is sim time [s]).", COLUMNS)
    return out


# -- messages that are not only numbers (live recordings) ------------------------------------------------------

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
