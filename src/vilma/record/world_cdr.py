"""How a recording writes the 3D plant's world sensors: camera images and laser scans as ROS 2 messages (CDR),
with the topics a ROS camera and laser driver publish beside them. The header stamp is sim time, the frame the
sensor's name (placed on the car by ``tf_static``, :mod:`vilma.record.sensor_frames`; a camera's is the ROS optical
frame, z forward, x right, y down, the image's first row its top):

============================= =============================== ===================================================
topic                         type                            content
============================= =============================== ===================================================
``camera/<name>``             sensor_msgs/msg/Image           ``rgb8``, exact (the default)
                              sensor_msgs/msg/CompressedImage ``jpeg`` at the recorder's ``jpeg_quality``
``camera/<name>/camera_info`` sensor_msgs/msg/CameraInfo      beside each colour image when the recorder knows
                                                              the camera: pinhole K, P from its focal length
                                                              and size, principal point at the image centre,
                                                              ``plumb_bob`` D all zero (MuJoCo has no distortion)
``camera/<name>/depth``       sensor_msgs/msg/Image           ``32FC1`` [m], exact
``laser``                     sensor_msgs/msg/LaserScan       a laser of one layer: ranges float32 a ray (inf:
                                                              no hit), intensities none; the angles and limits
                                                              of the recorder's laser
``laser/points``              sensor_msgs/msg/PointCloud2     beside that LaserScan, the hits: one row of
                                                              ``x, y, z`` float32 [m]
``laser``                     sensor_msgs/msg/PointCloud2     a laser of several layers, organized (as the ROS
                                                              drivers of multi-layer lidars publish): a row a
                                                              layer, a column a bearing, in scan order; fields
                                                              ``x, y, z`` float32 [m] (NaN: no hit), ``range``
                                                              float32 [m] (inf: no hit), ``ring`` uint16 (the
                                                              layer's index in ``LaserParams.layers``), 2 bytes
                                                              of padding (:data:`POINT_STEP`); no
                                                              ``laser/points`` beside
============================= =============================== ===================================================

Why raw colour by default: the bytes read back exactly, and MuJoCo's flat-shaded renders are large areas of one
colour, which the chunks' zstd (level 1) packs about as small as JPEG does: the 3D course's first 640x480 frame is
922 kB raw, 1.7 kB after zstd, against 10 kB as JPEG 90, 2.4 kB after zstd (and JPEG takes milliseconds a frame
and shifts colours by a few levels);
the 60 s ``course_3d_obstacles`` run (320x240 stereo with depth at 10 Hz, the laser) is 80.0 MB with raw colour,
79.2 MB with JPEG (the depth maps are most of it). A textured or noisy world compresses less: give
``jpeg_quality`` then. Depth maps are always raw (a depth map must not be smeared). Why two laser
topics for one layer: a LaserScan holds the ranges but not vilma's hit points (float32 from the float64 ray
directions, not recomputable bit for bit), which only a point cloud carries. Why a point cloud alone for several
layers: a LaserScan describes one fan of rays (its ranges must number ``(angle_max - angle_min) / angle_increment +
1``), so one holding several layers one after another, as recordings before this held them (:func:`decode_world`
still reads those), is invalid and drawn wrong; the organized cloud holds the ranges and the hits (the hits' own
float32 ``x, y, z`` at their rays, in the order the laser makes them), so both read back bit for bit.
Recordings made before these types wrote Foxglove's JSON schemas (:mod:`vilma.record.world_schemas`);
:func:`decode_world` reads both.
"""

from __future__ import annotations

import io
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from vilma.core.messages import Image, Message, PointCloud
from vilma.plant3d.camera import CameraParams
from vilma.plant3d.laser import LaserParams
from vilma.record import world_schemas as js
from vilma.record.cdr import CdrBody, CdrReader
from vilma.record.schemas import _HEADER, _STAMPED, _TIME, ros2msg

IMAGE, COMPRESSED_IMAGE, CAMERA_INFO = ("sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage",
                                        "sensor_msgs/msg/CameraInfo")
LASER_SCAN, POINT_CLOUD2 = "sensor_msgs/msg/LaserScan", "sensor_msgs/msg/PointCloud2"
WORLD_SCHEMAS = (IMAGE, COMPRESSED_IMAGE, LASER_SCAN, *js.WORLD_SCHEMAS)
"""The types of world sensors' own topics (not those beside them), these and those of older recordings; and a
PointCloud2 on ``laser`` (:func:`is_world`)."""
LASER, POINTS = "laser", "laser/points"
"""The laser's topic, and that of a LaserScan's hit points."""
UINT16, FLOAT32 = 4, 7
"""``sensor_msgs/PointField`` datatypes of a uint16 and a float32."""
POINT_STEP = 20
"""Bytes a point of a multi-layer laser's organized cloud: ``x, y, z, range`` float32 at 0, 4, 8, 12, ``ring``
uint16 at 16, then 2 bytes of zeros so that every point's floats stay 4-byte aligned."""
_XYZ = np.dtype({"names": ["x", "y", "z"], "formats": ["<f4"] * 3, "offsets": [0, 4, 8], "itemsize": 12})
_LAYERED = np.dtype({"names": ["x", "y", "z", "range", "ring"], "formats": ["<f4", "<f4", "<f4", "<f4", "<u2"],
                     "offsets": [0, 4, 8, 12, 16], "itemsize": POINT_STEP})

_IMAGE_SCHEMA = ros2msg(_STAMPED + "uint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\n"
                        "uint8[] data", _HEADER, _TIME)
_COMPRESSED_SCHEMA = ros2msg(_STAMPED + "string format\nuint8[] data", _HEADER, _TIME)
_CAMERA_INFO_SCHEMA = ros2msg(
    _STAMPED + "uint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\n"
    "float64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi", _HEADER, _TIME,
    "MSG: sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\n"
    "bool do_rectify")
_LASER_SCAN_SCHEMA = ros2msg(_STAMPED + "float32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\n"
                             "float32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\n"
                             "float32[] ranges\nfloat32[] intensities", _HEADER, _TIME)
_POINT_CLOUD2_SCHEMA = ros2msg(
    _STAMPED + "uint32 height\nuint32 width\nsensor_msgs/PointField[] fields\nbool is_bigendian\n"
    "uint32 point_step\nuint32 row_step\nuint8[] data\nbool is_dense", _HEADER, _TIME,
    "MSG: sensor_msgs/PointField\nuint8 INT8 = 1\nuint8 UINT8 = 2\nuint8 INT16 = 3\nuint8 UINT16 = 4\n"
    "uint8 INT32 = 5\nuint8 UINT32 = 6\nuint8 FLOAT32 = 7\nuint8 FLOAT64 = 8\nstring name\nuint32 offset\n"
    "uint8 datatype\nuint32 count")
SCHEMAS = {IMAGE: _IMAGE_SCHEMA, COMPRESSED_IMAGE: _COMPRESSED_SCHEMA, CAMERA_INFO: _CAMERA_INFO_SCHEMA,
           LASER_SCAN: _LASER_SCAN_SCHEMA, POINT_CLOUD2: _POINT_CLOUD2_SCHEMA}
"""ROS 2 type -> its ``ros2msg`` schema (ROS 2 Humble's definition)."""

WorldSensorParams = CameraParams | LaserParams


@dataclass(frozen=True, slots=True)
class WorldChannels:
    """How one world topic is written: the topics (itself, then those beside it) with their ROS 2 types."""

    topics: tuple[tuple[str, str], ...]
    """(topic, ROS 2 type) each."""
    encode: Callable[[Message], tuple[bytes, ...]]
    """The CDR payloads of one message, one a topic; raises :class:`~vilma.record.world_schemas.WorldMessageError`
    for a malformed one."""


def sensor_topics(sensors: tuple[WorldSensorParams, ...]) -> dict[str, WorldSensorParams]:
    """World topic -> the parameters of the sensor publishing it."""
    out: dict[str, WorldSensorParams] = {}
    for s in sensors:
        if isinstance(s, LaserParams):
            out[LASER] = s
        else:
            out[f"camera/{s.name}"] = out[f"camera/{s.name}/depth"] = s
    return out


def _image(m: Image) -> bytes:
    return (CdrBody().header(m.frame_id, m.stamp_ns).number("I", m.height, m.width).string(m.encoding)
            .number("B", 0).number("I", m.step).sequence(m.data)).payload()[0]


def _jpeg(quality: int) -> Callable[[Image], bytes]:
    from PIL import Image as PILImage  # here: a recording without JPEG images never needs Pillow

    def encode(m: Image) -> bytes:
        buf = io.BytesIO()
        PILImage.frombuffer("RGB", (m.width, m.height), m.data, "raw", "RGB", m.step, 1).save(
            buf, format="JPEG", quality=quality)
        return CdrBody().header(m.frame_id, m.stamp_ns).string("jpeg").sequence(buf.getvalue()).payload()[0]
    return encode


def camera_info(p: CameraParams, stamp_ns: int) -> bytes:
    """The ``sensor_msgs/msg/CameraInfo`` of camera ``p`` at ``stamp_ns`` [ns]: pinhole, square pixels, the
    principal point at the image centre (pixel centres at whole coordinates, as ROS and OpenCV count them)."""
    f, cx, cy = p.focal_px, (p.width - 1) / 2, (p.height - 1) / 2
    return (CdrBody().header(p.name, stamp_ns).number("I", p.height, p.width).string("plumb_bob")
            .sequence(bytes(5 * 8), 8).number("d", f, 0, cx, 0, f, cy, 0, 0, 1).number("d", 1, 0, 0, 0, 1, 0, 0, 0, 1)
            .number("d", f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0).number("I", 0, 0, 0, 0, 0, 0).number("?", False)
            ).payload()[0]


def _camera(name: str, camera: CameraParams | None, jpeg_quality: int | None) -> WorldChannels:
    encoding = js.image_encoding(name)
    jpeg = encoding == js.RGB and js.check_jpeg_quality(jpeg_quality) is not None
    image = _jpeg(jpeg_quality) if jpeg else _image
    topics = ((name, COMPRESSED_IMAGE if jpeg else IMAGE),)
    with_info = camera is not None and encoding == js.RGB
    if with_info:
        topics += ((f"{name}/camera_info", CAMERA_INFO),)

    def encode(msg: Message) -> tuple[bytes, ...]:
        m = js.checked_image(msg, encoding)
        if camera is not None and (m.width, m.height) != (camera.width, camera.height):
            raise js.WorldMessageError(f"{m.width}x{m.height} px, but camera {camera.name!r} makes "
                                       f"{camera.width}x{camera.height}")
        return (image(m), camera_info(camera, m.stamp_ns)) if with_info else (image(m),)
    return WorldChannels(topics, encode)


def _laser(laser: LaserParams | None) -> WorldChannels:
    layered = laser is not None and len(laser.layers) > 1

    def encode(msg: Message) -> tuple[bytes, ...]:
        problem = js.cloud_problem(msg)
        if problem is None and laser is None:
            problem = "the recorder was not given the laser's parameters, which a LaserScan needs"
        rays = len(laser.bearings) * len(laser.layers) if laser is not None else 0
        if problem is None and len(msg.ranges) != 4 * rays:
            problem = f"{len(msg.ranges) // 4} ranges, but laser {laser.name!r} casts {rays} rays"
        if problem is not None:
            raise js.WorldMessageError(problem)
        if layered:
            return (_layered_cloud(msg, len(laser.layers), len(laser.bearings)),)
        b = laser.bearings
        scan = (CdrBody().header(msg.frame_id, msg.stamp_ns)
                .number("f", b[0], b[-1], math.radians(laser.resolution), 0, 1 / laser.rate_hz,  # one instant
                        laser.min_range, laser.max_range).sequence(msg.ranges, 4).sequence(b"", 4)).payload()[0]
        return scan, _cloud2(msg, 1, len(msg.points) // 12, _XYZ, msg.points, dense=True)
    if layered:
        return WorldChannels(((LASER, POINT_CLOUD2),), encode)
    return WorldChannels(((LASER, LASER_SCAN), (POINTS, POINT_CLOUD2)), encode)


def _layered_cloud(msg: PointCloud, layers: int, bearings: int) -> bytes:
    """The organized ``sensor_msgs/msg/PointCloud2`` of a checked scan of ``layers`` x ``bearings`` rays: each
    hit's own ``x, y, z`` bytes at its ray (hits and rays are both in scan order), NaN at the others."""
    ranges = np.frombuffer(msg.ranges, "<f4")
    cloud = np.zeros(layers * bearings, _LAYERED)
    hits = np.frombuffer(msg.points, "<f4").reshape(-1, 3)
    hit = np.isfinite(ranges)
    for k, axis in enumerate("xyz"):
        cloud[axis] = np.nan
        cloud[axis][hit] = hits[:, k]
    cloud["range"] = ranges
    cloud["ring"] = np.repeat(np.arange(layers, dtype="<u2"), bearings)
    return _cloud2(msg, layers, bearings, _LAYERED, cloud.tobytes(), dense=False)


def _cloud2(msg: PointCloud, height: int, width: int, point: np.dtype, data: bytes, dense: bool) -> bytes:
    """A little-endian ``sensor_msgs/msg/PointCloud2`` of ``msg``'s stamp and frame: ``height`` x ``width`` points
    laid out as the structured dtype ``point`` (float32 and uint16 fields) in ``data``."""
    body = CdrBody().header(msg.frame_id, msg.stamp_ns).number("I", height, width).number("I", len(point.names))
    for name in point.names:
        kind, offset = point.fields[name]
        body.string(name).number("I", offset).number("B", UINT16 if kind.kind == "u" else FLOAT32).number("I", 1)
    body.number("?", False).number("I", point.itemsize, point.itemsize * width).sequence(data)
    return body.number("?", dense).payload()[0]


def world_channels(name: str, sensor: WorldSensorParams | None = None, jpeg_quality: int | None = None
                   ) -> WorldChannels:
    """How world topic ``name`` is written (see the module docstring), given its sensor's parameters if known
    (without them: no camera info, and a laser scan is dropped); ``jpeg_quality`` 1..95: colour as JPEG."""
    if name == LASER:
        return _laser(sensor if isinstance(sensor, LaserParams) else None)
    return _camera(name, sensor if isinstance(sensor, CameraParams) else None, jpeg_quality)


def is_world(name: str, schema_name: str) -> bool:
    """Whether topic ``name`` of type ``schema_name`` is a world sensor's own topic (not one beside it)."""
    return schema_name in WORLD_SCHEMAS or (name == LASER and schema_name == POINT_CLOUD2)


def decode_world(schema_name: str, payload: bytes, *beside: bytes) -> Message:
    """The vilma message of one recorded world-sensor payload (and, for a LaserScan, its ``laser/points``
    payload beside); a JPEG image comes back as its decoded pixels, a PointCloud2 (a multi-layer laser's) as the
    scan whose rays its points are, row by row.

    Raises:
        ValueError: not a world schema, or a payload that does not decode (one line).
    """
    if schema_name not in (IMAGE, COMPRESSED_IMAGE, LASER_SCAN, POINT_CLOUD2):
        return js.decode_world(schema_name, payload)
    try:
        r = CdrReader(payload)
        stamp_ns, frame_id = r.time(), r.string()
        if schema_name == IMAGE:
            height, width, encoding = *r.number("I", 2), r.string()
            r.number("B")
            step = r.number("I")
            return Image(stamp_ns, frame_id, width, height, encoding, step, bytes(r.sequence()))
        if schema_name == COMPRESSED_IMAGE:
            from PIL import Image as PILImage

            r.string()
            with PILImage.open(io.BytesIO(r.sequence())) as img:
                rgb = img.convert("RGB")
            w, h = rgb.size
            return Image(stamp_ns, frame_id, w, h, js.RGB, 3 * w, rgb.tobytes())
        if schema_name == POINT_CLOUD2:
            return _scan_of_cloud(stamp_ns, frame_id, r)
        r.number("f", 7)
        ranges = bytes(r.sequence(4))
        p = CdrReader(beside[0])
        p.time(), p.string(), p.number("I", 2)
        for _ in range(p.number("I")):
            p.string(), p.number("I"), p.number("B"), p.number("I")
        p.number("?"), p.number("I", 2)
        return PointCloud(stamp_ns, frame_id, bytes(p.sequence()), ranges)
    except (ValueError, OSError, IndexError) as e:
        raise ValueError(f"a {schema_name} message does not decode: {e}") from None


def _scan_of_cloud(stamp_ns: int, frame_id: str, r: CdrReader) -> PointCloud:
    """The scan of a PointCloud2 read up to its header: the ``range`` field of every point in row order, the
    ``x, y, z`` of those whose range is finite (any layout of float32 fields, either byte order)."""
    height, width = r.number("I", 2)
    fields = {}
    for _ in range(r.number("I")):
        name, offset, datatype, count = r.string(), r.number("I"), r.number("B"), r.number("I")
        fields[name] = (offset, datatype, count)
    order = ">" if r.number("?") else "<"
    point_step, row_step = r.number("I", 2)
    data = r.sequence()
    r.number("?")  # is_dense: NaN points or not, the ranges say which are hits
    want = ("x", "y", "z", "range")
    missing = [k for k in want if k not in fields or fields[k][1:] != (FLOAT32, 1)]
    if missing:
        raise ValueError(f"no float32 field {', '.join(missing)} (a laser scan needs x, y, z and range)")
    if row_step < width * point_step or len(data) < height * row_step:
        raise ValueError(f"{len(data)} bytes of data, less than {height} rows of {width} points of {point_step} "
                         f"bytes (row step {row_step})")
    dtype = np.dtype({"names": list(want), "formats": [order + "f4"] * 4,
                      "offsets": [fields[k][0] for k in want], "itemsize": point_step})
    rows = np.frombuffer(data, np.uint8, height * row_step).reshape(height, row_step)[:, :width * point_step]
    cloud = np.ascontiguousarray(rows).view(dtype).reshape(-1)
    ranges = cloud["range"].astype("<f4")
    hit = np.isfinite(ranges)
    points = np.column_stack([cloud[k][hit] for k in "xyz"]).astype("<f4")
    return PointCloud(stamp_ns, frame_id, points.tobytes(), ranges.tobytes())


def points_of(schema_name: str) -> str | None:
    """The topic, beside a world topic of type ``schema_name``, that :func:`decode_world` needs too."""
    return POINTS if schema_name == LASER_SCAN else None
