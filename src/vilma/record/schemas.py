"""How each topic is written in a recording: channel, schema and bytes, packed in bulk from arrays.

Numeric topics are ROS 2 messages (``ros2msg`` schemas, CDR payloads, as
``ros2 bag`` writes them), which Foxglove, Lichtblick, PlotJuggler and ROS 2
tools decode from the file alone. A sensor is written in the standard type that
fits it, with a second topic for what that type cannot carry exactly, so that
every value reads back bit for bit (NaN and infinities included); the header
stamp is sim time:

================== ================================ ========================================================
topic              type                             content
================== ================================ ========================================================
``pose``           geometry_msgs/msg/PoseStamped    frame ``map``; quaternion from roll, pitch, yaw
``pose/euler``     geometry_msgs/msg/Vector3Stamped roll, pitch, yaw [rad] as they are (x, y, z)
``tf``             foxglove_msgs/msg/FrameTransform ``map`` -> ``<car>``, from the pose
``tf_static``      foxglove_msgs/msg/FrameTransform ``<car>`` -> each camera's and laser's frame (its name):
                                                    its mount, stamp 0 (:mod:`vilma.record.sensor_frames`)
``velocity``       geometry_msgs/msg/TwistStamped   frame ``<car>``: body velocity [m/s], body rates [rad/s]
``velocity/world`` geometry_msgs/msg/Vector3Stamped frame ``map``: world-frame velocity [m/s]
``gps``            sensor_msgs/msg/NavSatFix        latitude, longitude [deg], altitude [m]; frame ``gps``
``gps/enu``        geometry_msgs/msg/PointStamped   frame ``map``: the fix's local ENU x, y, z [m]
``imu``            sensor_msgs/msg/Imu              frame ``<car>``; covariances unknown (zeros)
``odometry``       nav_msgs/msg/Odometry            frame ``odom``, child ``<car>``; x, y, yaw; speed and yaw
                                                    rate in the twist; covariances unknown (zeros)
``odometry/euler`` geometry_msgs/msg/Vector3Stamped frame ``odom``: 0, 0, yaw [rad] as it is
``wheel_speed``    vilma_msgs/msg/WheelSpeeds       (no standard type) fl, fr, rl, rr [rad/s]
``actuators``      vilma_msgs/msg/ActuatorState     (no standard type) steer [rad], drive and brake force [N]
``drive_log``      vilma_msgs/msg/DriveLogRow       the runner's row a control period (true plant + driver)
================== ================================ ========================================================

A ``vilma_msgs/msg/<Type>`` has a ``builtin_interfaces/Time stamp`` and the message's float64 fields, unit in
a comment. Recordings made before the standard types have every sensor so (and ``gps/fix``, a
``foxglove_msgs/msg/LocationFix``): :func:`vilma_layouts` reads them.

Every numeric message has a fixed size (its strings, the frames, are constants), so a column of them is packed
in one compiled loop (:mod:`vilma.record.cdr`). Messages that are not only numbers (orders, statuses) are JSON
objects with a ``vilma.<Type>`` JSON schema; so are the objects sensor's lists (``objects``, ``vilma.ObjectList``,
an object's fields by name): of varying length, they have no fixed size, and neither ROS 2's common interfaces
nor Foxglove's schemas have a list of true objects with id, pose, speed and size.
"""

from __future__ import annotations

import functools
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
from vilma.record.cdr import RECORD_HEADER, CdrBody, pack_records, payload_dtype, runs, stamps_of
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
TF, TF_STATIC = "tf", "tf_static"
"""The car's frame in the map, derived from ``pose``; the world sensors' frames on the car, from their mounts
(:mod:`vilma.record.sensor_frames`): both ``foxglove_msgs/msg/FrameTransform``."""
OBJECTS_SCENE, PLAN_SCENE = "perception/objects/scene", "planning/plan/scene"
"""The tracks and the plans drawn as Foxglove scene primitives (:mod:`vilma.record.plan_scene`)."""
COMPANIONS = {"pose": ("pose/euler", TF), "velocity": ("velocity/world",), "gps": ("gps/enu",),
              "odometry": ("odometry/euler",), "perception/objects": (OBJECTS_SCENE,), "planning/plan": (PLAN_SCENE,)}
"""Topic -> the topics written beside it from each of its messages (what its standard type cannot carry
exactly, ``tf``, and the scenes drawing the tracks and plans)."""

_SEPARATOR = "=" * 80
_TIME = "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec"
_HEADER = "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id"
_VECTOR3 = "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z"
_POINT = "MSG: geometry_msgs/Point\nfloat64 x\nfloat64 y\nfloat64 z"
_QUATERNION = "MSG: geometry_msgs/Quaternion\nfloat64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1"
_POSE = "MSG: geometry_msgs/Pose\ngeometry_msgs/Point position\ngeometry_msgs/Quaternion orientation"
_TWIST = "MSG: geometry_msgs/Twist\ngeometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular"
_NAV_SAT_STATUS = ("MSG: sensor_msgs/NavSatStatus\nint8 STATUS_NO_FIX = -1\nint8 STATUS_FIX = 0\n"
                   "int8 STATUS_SBAS_FIX = 1\nint8 STATUS_GBAS_FIX = 2\nint8 status\nuint16 SERVICE_GPS = 1\n"
                   "uint16 SERVICE_GLONASS = 2\nuint16 SERVICE_COMPASS = 4\nuint16 SERVICE_GALILEO = 8\n"
                   "uint16 service")
_STAMPED = "std_msgs/Header header\n"


def ros2msg(definition: str, *dependencies: str) -> bytes:
    """A ``ros2msg`` schema: the message's definition, then each type it uses (``MSG: pkg/Type`` and its own)."""
    return "\n".join([definition, *(f"{_SEPARATOR}\n{d}" for d in dependencies)]).encode() + b"\n"


@dataclass(frozen=True, slots=True)
class Layout:
    """How one numeric topic is written: its ROS 2 type and the CDR payload, a template with slots.

    A topic is written from the values (n, k) of a source topic (itself, or the topic it goes beside): its
    float64 slots take the values ``picks`` points at, or, if ``floats`` is given, what it makes of them (of
    the values of one message (k,) too).
    ``fields`` names the source's field each float64 slot holds as it is (None where it is computed): what
    reading back takes from this topic.
    """

    schema_name: str
    schema: bytes
    payload: bytes
    slots: tuple[int, ...]
    fields: tuple[str | None, ...]
    picks: tuple[int, ...] = ()
    floats: Callable[[np.ndarray], np.ndarray] | None = None

    def _floats(self, values: np.ndarray) -> np.ndarray:
        if self.floats is not None:
            return self.floats(values)
        return values if self.picks == tuple(range(values.shape[1])) else values[:, self.picks]

    def records(self, stamps: np.ndarray, values: np.ndarray, channel: int, out: np.ndarray | None = None
                ) -> np.ndarray:
        """The MCAP Message records of the rows on ``channel`` (bytes as uint8, each of :attr:`record_size`; in
        ``out`` if given)."""
        return pack_records(self.payload, self.slots, channel, stamps, self._floats(values), out)

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
        """The payload of one message from its source's values (fields after ``stamp_ns``), as :meth:`encode`
        writes it (without numpy unless computed: a live program's path, message by message)."""
        row = ([values[i] for i in self.picks] if self.floats is None
               else self.floats(np.array(values, np.float64)).tolist())
        out = bytearray(self.payload)
        struct.pack_into("<iI", out, self.slots[0], *divmod(stamp_ns, 1_000_000_000))
        for at, first, count in runs(self.slots):
            struct.pack_into(f"<{count}d", out, at, *row[first:first + count])
        return bytes(out)

    def decode(self, payloads: list[bytes]) -> tuple[np.ndarray, np.ndarray]:
        """Stamps [ns] and float64 slots (n, len(slots) - 1) of payloads this layout wrote.

        Raises:
            ValueError: a payload of another size (another type, or a file written otherwise).
        """
        size = len(self.payload)
        bad = next((len(p) for p in payloads if len(p) != size), None)
        if bad is not None:
            raise ValueError(f"a {self.schema_name} message of {bad} bytes, not {size}")
        rows = np.frombuffer(b"".join(payloads), payload_dtype(self.payload, self.slots))
        floats = [rows[f"f{i}"] for i in range(len(self.slots) - 1)]
        return stamps_of(rows["sec"], rows["nanosec"]), np.stack(floats, axis=1).astype(np.float64)


def _picked(schema_name: str, schema: bytes, body: CdrBody, source: tuple[str, ...], fields: tuple[str, ...]
            ) -> Layout:
    """A layout whose float64 slots are ``fields`` of a source with fields ``source``, as they are."""
    payload, slots = body.payload()
    return Layout(schema_name, schema, payload, slots, fields, tuple(source.index(f) for f in fields))


def _vilma_layout(type_name: str, doc: str, fields: tuple[str, ...]) -> Layout:
    lines = [f"# {doc}", "builtin_interfaces/Time stamp  # sim time",
             *(f"float64 {f}" + (f"  # [{_UNITS[f]}]" if f in _UNITS else "") for f in fields)]
    return _picked(f"vilma_msgs/msg/{type_name}", ros2msg("\n".join(lines), _TIME),
                   CdrBody().time().float64(len(fields)), fields, fields)


def _fields(name: str) -> tuple[str, ...]:
    return SENSOR_TOPICS[name].__struct_fields__[1:]


def _quaternions(roll, pitch, yaw) -> np.ndarray:
    """Quaternions ``(..., 4)`` of ZYX Euler angles [rad] (arrays of one shape, or numbers)."""
    with np.errstate(invalid="ignore"):  # an infinite angle: no orientation, NaN
        return np.stack(quaternion_from_euler(roll, pitch, yaw), axis=-1)


def _position_quaternion(v: np.ndarray) -> np.ndarray:
    """x, y, z and the quaternion of a pose's values (..., 6): x, y, z, roll, pitch, yaw."""
    return np.concatenate([v[..., :3], _quaternions(v[..., 3], v[..., 4], v[..., 5])], axis=-1)


FRAME_TRANSFORM = "foxglove_msgs/msg/FrameTransform"
FRAME_TRANSFORM_SCHEMA = ros2msg("builtin_interfaces/Time timestamp\nstring parent_frame_id\n"
                                 "string child_frame_id\ngeometry_msgs/Vector3 translation\n"
                                 "geometry_msgs/Quaternion rotation", _TIME, _VECTOR3, _QUATERNION)
"""The ``ros2msg`` schema of :data:`TF` and :data:`TF_STATIC`."""


def _tf_layout(car: str) -> Layout:
    payload, slots = CdrBody().time().string("map").string(car).float64(7).payload()
    return Layout(FRAME_TRANSFORM, FRAME_TRANSFORM_SCHEMA, payload, slots, (None,) * 7, floats=_position_quaternion)


def _pose_layout() -> Layout:
    payload, slots = CdrBody().header("map").float64(7).payload()
    return Layout("geometry_msgs/msg/PoseStamped",
                  ros2msg(_STAMPED + "geometry_msgs/Pose pose", _HEADER, _TIME, _POSE, _POINT, _QUATERNION),
                  payload, slots, ("x", "y", "z", None, None, None, None), floats=_position_quaternion)


def _vector3_layout(frame: str, source: tuple[str, ...], fields: tuple[str, ...]) -> Layout:
    """A ``geometry_msgs/msg/Vector3Stamped`` of ``fields`` (x, y, z; fewer: zeros first)."""
    body = CdrBody().header(frame).zeros(3 - len(fields), 8).float64(len(fields))
    return _picked("geometry_msgs/msg/Vector3Stamped",
                   ros2msg(_STAMPED + "geometry_msgs/Vector3 vector", _HEADER, _TIME, _VECTOR3), body, source, fields)


def _twist_layout(car: str) -> Layout:
    return _picked("geometry_msgs/msg/TwistStamped",
                   ros2msg(_STAMPED + "geometry_msgs/Twist twist", _HEADER, _TIME, _TWIST, _VECTOR3),
                   CdrBody().header(car).float64(6), _fields("velocity"), ("vx", "vy", "vz", "wx", "wy", "wz"))


def _nav_sat_fix_layout() -> Layout:
    definition = (_STAMPED + "sensor_msgs/NavSatStatus status\nfloat64 latitude\nfloat64 longitude\n"
                  "float64 altitude\nfloat64[9] position_covariance\nuint8 COVARIANCE_TYPE_UNKNOWN = 0\n"
                  "uint8 COVARIANCE_TYPE_APPROXIMATED = 1\nuint8 COVARIANCE_TYPE_DIAGONAL_KNOWN = 2\n"
                  "uint8 COVARIANCE_TYPE_KNOWN = 3\nuint8 position_covariance_type")
    body = (CdrBody().header("gps").number("b", 0).number("H", 1)  # STATUS_FIX, SERVICE_GPS
            .float64(3).zeros(9, 8).zeros(1, 1))  # covariance unknown
    return _picked("sensor_msgs/msg/NavSatFix", ros2msg(definition, _HEADER, _TIME, _NAV_SAT_STATUS), body,
                   _fields("gps"), ("latitude", "longitude", "altitude"))


def _point_layout(frame: str, source: tuple[str, ...], fields: tuple[str, ...]) -> Layout:
    return _picked("geometry_msgs/msg/PointStamped", ros2msg(_STAMPED + "geometry_msgs/Point point", _HEADER, _TIME,
                                                             _POINT), CdrBody().header(frame).float64(3), source,
                   fields)


def _imu_layout(car: str) -> Layout:
    definition = (_STAMPED + "geometry_msgs/Quaternion orientation\nfloat64[9] orientation_covariance\n"
                  "geometry_msgs/Vector3 angular_velocity\nfloat64[9] angular_velocity_covariance\n"
                  "geometry_msgs/Vector3 linear_acceleration\nfloat64[9] linear_acceleration_covariance")
    body = (CdrBody().header(car).float64(4).zeros(9, 8)  # all-zero covariances: unknown
            .float64(3).zeros(9, 8).float64(3).zeros(9, 8))
    return _picked("sensor_msgs/msg/Imu", ros2msg(definition, _HEADER, _TIME, _QUATERNION, _VECTOR3), body,
                   _fields("imu"), ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az"))


def _odometry_layout(car: str) -> Layout:
    definition = (_STAMPED + "string child_frame_id\ngeometry_msgs/PoseWithCovariance pose\n"
                  "geometry_msgs/TwistWithCovariance twist")
    body = (CdrBody().header("odom").string(car)
            .float64(2).zeros(3, 8).float64(2).zeros(36, 8)  # x, y, z 0; quaternion x, y 0, z, w
            .float64(1).zeros(4, 8).float64(1).zeros(36, 8))  # linear x; angular z; covariances unknown
    payload, slots = body.payload()

    def floats(v):  # x, y, the quaternion's z and w, speed, yaw rate
        return np.concatenate([v[..., :2], _quaternions(0.0, 0.0, v[..., 2])[..., 2:], v[..., 3:5]], axis=-1)
    return Layout("nav_msgs/msg/Odometry", ros2msg(
        definition, _HEADER, _TIME, "MSG: geometry_msgs/PoseWithCovariance\ngeometry_msgs/Pose pose\n"
        "float64[36] covariance", _POSE, _POINT, _QUATERNION, "MSG: geometry_msgs/TwistWithCovariance\n"
        "geometry_msgs/Twist twist\nfloat64[36] covariance", _TWIST, _VECTOR3),
        payload, slots, ("x", "y", None, None, "speed", "yaw_rate"), floats=floats)


@functools.cache
def vilma_layouts() -> dict[str, Layout]:
    """Topic name -> its ``vilma_msgs/msg/<Type>`` layout, for every sensor and ``drive_log`` (how vilma wrote
    them all before the standard types)."""
    out = {name: _vilma_layout(cls.__name__, (cls.__doc__ or "").split("\n")[0], cls.__struct_fields__[1:])
           for name, cls in SENSOR_TOPICS.items()}
    out[DRIVE_LOG] = _vilma_layout("DriveLogRow", "The runner's row a control period: the true plant and the "
                                   "driver (t is sim time [s]).", COLUMNS)
    return out


@functools.cache
def numeric_layouts(car: str) -> dict[str, Layout]:
    """Topic name (within the car) -> layout, for every topic made of numbers (and those written beside them,
    :data:`COMPANIONS`)."""
    pose, velocity, gps, odometry = (_fields(n) for n in ("pose", "velocity", "gps", "odometry"))
    return {
        **vilma_layouts(),
        "pose": _pose_layout(), "pose/euler": _vector3_layout("map", pose, ("roll", "pitch", "yaw")),
        TF: _tf_layout(car),
        "velocity": _twist_layout(car),
        "velocity/world": _vector3_layout("map", velocity, ("vx_world", "vy_world", "vz_world")),
        "gps": _nav_sat_fix_layout(), "gps/enu": _point_layout("map", gps, ("x", "y", "z")),
        "imu": _imu_layout(car),
        "odometry": _odometry_layout(car), "odometry/euler": _vector3_layout("odom", odometry, ("yaw",)),
    }


def channels(name: str) -> tuple[str, ...]:
    """The topics written from each message of topic ``name``: itself and its :data:`COMPANIONS`."""
    return (name, *COMPANIONS.get(name, ()))


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
        elif isinstance(v, list) and v and isinstance(v[0], dict):  # nested structs (ObjectList's objects)
            v = msgspec.convert(v, f.type)
        if v is not None:
            kw[f.name] = v
    return cls(**kw)
