"""The 3D plant's world sensors in Foxglove's well-known schemas, as JSON: how the live Foxglove view sends camera
images and laser scans, and how recordings held them before the ROS 2 types of :mod:`vilma.record.world_cdr`
(bytes fields are base64 strings, ``"contentEncoding": "base64"`` in the schema, as Foxglove's JSON encoding
requires):

- ``camera/<name>`` (``rgb8``): ``foxglove.CompressedImage``, JPEG at ``jpeg_quality``, with vilma's ``width``,
  ``height`` and ``encoding`` beside. JPEG is lossy: reading back gives the JPEG-decoded pixels, not the
  rendered ones (within a few grey levels on flat colours, more on edges). Why: a shaded 640x480 frame is
  1.2 MB of JSON raw, 0.7 MB after the chunks' zstd, against 30 kB as JPEG 90, so a stereo pair at 10 Hz is
  about 870 MB a minute raw and 28 MB as JPEG. With ``jpeg_quality=None``: ``foxglove.RawImage``, exact.
- ``camera/<name>/depth`` (``32FC1``): ``foxglove.RawImage``, exact (a depth map must not be smeared).
- ``laser``: ``foxglove.PointCloud`` (fields ``x, y, z`` float32, stride 12 bytes, identity pose in the laser's
  frame), with vilma's ``ranges`` (float32 a ray, inf: no hit) beside.

Every message also has ``stamp_ns`` (sim time [ns]). A malformed message (data length not ``height * step``,
points not whole triples...) raises :class:`WorldMessageError`, which the recorders turn into a warning.
"""

from __future__ import annotations

import io
import logging
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import msgspec
import numpy as np

from vilma.bus.topics import TOPICS, topic
from vilma.core.messages import Image, Message, PointCloud
from vilma.record.schemas import QUATERNION, TIMESTAMP, VECTOR3, object_schema

log = logging.getLogger(__name__)

JPEG_QUALITY = 90
"""JPEG quality of recorded colour images (Pillow's 1..95 scale)."""
RGB, DEPTH = "rgb8", "32FC1"
BYTES_PER_PIXEL = {RGB: 3, DEPTH: 4}
"""Image encodings vilma's cameras make -> bytes a pixel."""
FLOAT32 = 7
"""``foxglove.PackedElementField`` numeric type of a float32."""
COMPRESSED_IMAGE, RAW_IMAGE, POINT_CLOUD = "foxglove.CompressedImage", "foxglove.RawImage", "foxglove.PointCloud"
WORLD_SCHEMAS = (COMPRESSED_IMAGE, RAW_IMAGE, POINT_CLOUD)
"""The schemas world-sensor topics are written in."""


class WorldMessageError(ValueError):
    """A camera image or laser scan that cannot be recorded: one line saying what is wrong with it."""


def note_dropped(dropped: dict[str, int], where: str, name: str, error: WorldMessageError) -> None:
    """Count a malformed message of topic ``name`` in ``dropped``; the first of each topic is a one-line warning
    (``where``: who dropped it), the others are logged at debug level."""
    n = dropped[name] = dropped.get(name, 0) + 1
    log.log(logging.WARNING if n == 1 else logging.DEBUG, "%s %s: %s; message dropped", where, name, error)


def check_world_topics(names: Iterable[str]) -> tuple[str, ...]:
    """``names`` checked to be world sensor topics (``laser``, ``camera/<name>``, ``camera/<name>/depth``).

    Raises:
        ValueError: a name that is not one.
    """
    out = tuple(names)
    for name in out:
        try:
            topic(name)
        except ValueError:
            ok = False
        else:
            ok = name not in TOPICS
        if not ok:
            raise ValueError(f"world topic {name!r} is not a camera or laser topic: use laser, camera/<name> or "
                             f"camera/<name>/depth")
    return out


def check_jpeg_quality(quality: int | None) -> int | None:
    """``quality`` checked to be None (no JPEG) or 1..95; ValueError otherwise."""
    if quality is not None and (isinstance(quality, bool) or not isinstance(quality, int) or not 1 <= quality <= 95):
        raise ValueError(f"JPEG quality must be 1..95 (or None: raw images), got {quality!r}")
    return quality


def image_encoding(name: str) -> str:
    """The encoding a camera topic carries: ``32FC1`` on ``camera/<name>/depth``, else ``rgb8``."""
    return DEPTH if name.endswith("/depth") else RGB


def image_problem(msg: Message) -> str | None:
    """What is wrong with ``msg`` as an image (a known encoding, ``height`` rows of ``step`` bytes), or None."""
    if not isinstance(msg, Image):
        return f"a {type(msg).__name__}, not an Image"
    bpp = BYTES_PER_PIXEL.get(msg.encoding)
    if bpp is None:
        return f"encoding {msg.encoding!r} is not one of {', '.join(BYTES_PER_PIXEL)}"
    if msg.width <= 0 or msg.height <= 0:
        return f"size {msg.width}x{msg.height} px is empty"
    if msg.step < msg.width * bpp:
        return f"step {msg.step} bytes is less than width {msg.width} x {bpp} bytes"
    if len(msg.data) != msg.height * msg.step:
        return f"{len(msg.data)} bytes of data, not height {msg.height} x step {msg.step} = {msg.height * msg.step}"
    return None


def cloud_problem(msg: Message) -> str | None:
    """What is wrong with ``msg`` as a laser scan (whole xyz triples, one point a finite range), or None."""
    if not isinstance(msg, PointCloud):
        return f"a {type(msg).__name__}, not a PointCloud"
    if len(msg.points) % 12 or len(msg.ranges) % 4:
        return (f"{len(msg.points)} bytes of points and {len(msg.ranges)} of ranges: not whole float32 xyz "
                f"triples (12 bytes) and float32 ranges (4 bytes)")
    hits = int(np.isfinite(np.frombuffer(msg.ranges, "<f4")).sum())
    if hits != len(msg.points) // 12:
        return f"{len(msg.points) // 12} points for {hits} finite ranges"
    return None


# -- JSON ---------------------------------------------------------------------------------------------------


class _Time(msgspec.Struct):
    sec: int
    nsec: int


class _RawImage(msgspec.Struct):
    timestamp: _Time
    frame_id: str
    width: int
    height: int
    encoding: str
    step: int
    data: bytes
    stamp_ns: int


class _CompressedImage(msgspec.Struct):
    timestamp: _Time
    frame_id: str
    data: bytes
    format: str
    stamp_ns: int
    width: int
    height: int
    encoding: str


class _Field(msgspec.Struct):
    name: str
    offset: int
    type: int


class _Vector3(msgspec.Struct):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0


class _Quaternion(msgspec.Struct):
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    w: float = 1.0


class _Pose(msgspec.Struct):
    position: _Vector3 = msgspec.field(default_factory=_Vector3)
    orientation: _Quaternion = msgspec.field(default_factory=_Quaternion)


class _PointCloud(msgspec.Struct):
    timestamp: _Time
    frame_id: str
    pose: _Pose
    point_stride: int
    fields: list[_Field]
    data: bytes
    stamp_ns: int
    ranges: bytes


_enc = msgspec.json.Encoder()
_XYZ = [_Field(name=k, offset=4 * i, type=FLOAT32) for i, k in enumerate("xyz")]


def _time(stamp_ns: int) -> _Time:
    return _Time(stamp_ns // 1_000_000_000, stamp_ns % 1_000_000_000)


def _bytes(what: str) -> dict:
    return {"type": "string", "contentEncoding": "base64", "description": what}


_STAMP = {"type": "integer", "description": "sim time [ns]"}
_FRAME = {"type": "string", "description": "the sensor's frame"}
_SIZE = {"type": "integer", "minimum": 0}
_NUMERIC = {"title": "foxglove.NumericType", "oneOf": [
    {"title": t, "const": i} for i, t in enumerate(
        ("UNKNOWN", "UINT8", "INT8", "UINT16", "INT16", "UINT32", "INT32", "FLOAT32", "FLOAT64"))]}

_RAW_SCHEMA = object_schema(RAW_IMAGE, "A camera image as vilma's cameras render it (rgb8, or 32FC1 depth [m]).", {
    "timestamp": TIMESTAMP, "frame_id": _FRAME, "width": _SIZE, "height": _SIZE,
    "encoding": {"type": "string", "description": "rgb8, or 32FC1 (depth along the optical axis [m], "
                 "little-endian; inf: nothing within range)"},
    "step": {"type": "integer", "minimum": 0, "description": "bytes a row"},
    "data": _bytes("height rows of step bytes from the top-left pixel"), "stamp_ns": _STAMP},
    ["timestamp", "frame_id", "width", "height", "encoding", "step", "data"])
_JPEG_SCHEMA = object_schema(COMPRESSED_IMAGE, "A colour camera image, JPEG; vilma's size and encoding beside.", {
    "timestamp": TIMESTAMP, "frame_id": _FRAME, "data": _bytes("the JPEG file"),
    "format": {"type": "string", "description": "jpeg"}, "stamp_ns": _STAMP, "width": _SIZE, "height": _SIZE,
    "encoding": {"type": "string", "description": "the rendered image's encoding (rgb8)"}},
    ["timestamp", "frame_id", "data", "format"])
_CLOUD_SCHEMA = object_schema(POINT_CLOUD, "A laser scan's hits in the laser's frame (x forward, y left, z up "
                              "[m]); vilma's ranges a ray beside.", {
    "timestamp": TIMESTAMP, "frame_id": _FRAME,
    "pose": {"type": "object", "properties": {"position": VECTOR3, "orientation": QUATERNION}},
    "point_stride": {"type": "integer", "minimum": 0, "description": "bytes a point"},
    "fields": {"type": "array", "items": {"type": "object", "properties": {
        "name": {"type": "string"}, "offset": {"type": "integer", "minimum": 0}, "type": _NUMERIC}}},
    "data": _bytes("float32 little-endian x, y, z [m] a hit"), "stamp_ns": _STAMP,
    "ranges": _bytes("float32 little-endian range [m] a ray in scan order; inf: no hit within range")},
    ["timestamp", "frame_id", "pose", "point_stride", "fields", "data"])


def checked_image(msg: Message, encoding: str) -> Image:
    """``msg`` checked to be an image of ``encoding``; :class:`WorldMessageError` otherwise."""
    problem = image_problem(msg)
    if problem is None and msg.encoding != encoding:
        problem = f"encoding {msg.encoding}, but this topic carries {encoding}"
    if problem is not None:
        raise WorldMessageError(problem)
    return msg


def _encode_raw(encoding: str) -> Callable[[Message], bytes]:
    def encode(msg: Message) -> bytes:
        m = checked_image(msg, encoding)
        return _enc.encode(_RawImage(_time(m.stamp_ns), m.frame_id, m.width, m.height, m.encoding, m.step, m.data,
                                     m.stamp_ns))
    return encode


def _encode_jpeg(quality: int) -> Callable[[Message], bytes]:
    from PIL import Image as PILImage  # here: a recording without JPEG images never needs Pillow

    def encode(msg: Message) -> bytes:
        m = checked_image(msg, RGB)
        buf = io.BytesIO()
        PILImage.frombuffer("RGB", (m.width, m.height), m.data, "raw", "RGB", m.step, 1).save(
            buf, format="JPEG", quality=quality)
        return _enc.encode(_CompressedImage(_time(m.stamp_ns), m.frame_id, buf.getvalue(), "jpeg", m.stamp_ns,
                                            m.width, m.height, m.encoding))
    return encode


def _encode_cloud(msg: Message) -> bytes:
    problem = cloud_problem(msg)
    if problem is not None:
        raise WorldMessageError(problem)
    return _enc.encode(_PointCloud(_time(msg.stamp_ns), msg.frame_id, _Pose(), 12, _XYZ, msg.points, msg.stamp_ns,
                                   msg.ranges))


@dataclass(frozen=True, slots=True)
class WorldLayout:
    """How one world topic is written: schema name, JSON schema, and the JSON of a message."""

    schema_name: str
    schema: bytes
    encode: Callable[[Message], bytes]
    """The JSON of one message; raises :class:`WorldMessageError` for a malformed one."""


def world_layout(name: str, jpeg_quality: int | None = JPEG_QUALITY) -> WorldLayout:
    """The layout of world topic ``name`` (see the module docstring); ``jpeg_quality`` None: colour images raw."""
    if name == "laser":
        return WorldLayout(POINT_CLOUD, _CLOUD_SCHEMA, _encode_cloud)
    encoding = image_encoding(name)
    if encoding == RGB and check_jpeg_quality(jpeg_quality) is not None:
        return WorldLayout(COMPRESSED_IMAGE, _JPEG_SCHEMA, _encode_jpeg(jpeg_quality))
    return WorldLayout(RAW_IMAGE, _RAW_SCHEMA, _encode_raw(encoding))


def decode_world(schema_name: str, payload: bytes) -> Message:
    """The vilma message of one recorded world-sensor payload (a JPEG image comes back as its decoded pixels).

    Raises:
        ValueError: not a world schema, or a payload that does not decode (one line).
    """
    try:
        if schema_name == RAW_IMAGE:
            r = msgspec.json.decode(payload, type=_RawImage)
            return Image(r.stamp_ns, r.frame_id, r.width, r.height, r.encoding, r.step, r.data)
        if schema_name == COMPRESSED_IMAGE:
            from PIL import Image as PILImage

            c = msgspec.json.decode(payload, type=_CompressedImage)
            with PILImage.open(io.BytesIO(c.data)) as img:
                rgb = img.convert("RGB")
            w, h = rgb.size
            return Image(c.stamp_ns, c.frame_id, w, h, RGB, 3 * w, rgb.tobytes())
        if schema_name == POINT_CLOUD:
            p = msgspec.json.decode(payload, type=_PointCloud)
            return PointCloud(p.stamp_ns, p.frame_id, p.data, p.ranges)
    except (msgspec.DecodeError, OSError) as e:
        raise ValueError(f"a {schema_name} message does not decode: {e}") from None
    raise ValueError(f"{schema_name!r} is not a world sensor schema")


def compressed_image(payload: bytes) -> tuple[int, str, str, bytes]:
    """A recorded ``foxglove.CompressedImage`` as it is: ``(stamp_ns, frame_id, format, compressed bytes)``."""
    c = msgspec.json.decode(payload, type=_CompressedImage)
    return c.stamp_ns, c.frame_id, c.format, c.data

