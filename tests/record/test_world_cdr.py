"""Camera images and laser scans as ROS 2 messages: ROS 2 Humble's bytes, decoded by Foxglove's decoder, read back."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.typesys import Stores, get_typestore

from tests.record.ros2 import ros2_decoder
from tests.record.world_messages import GREY, LAYERED, depth_image, layered_scan, red_square, wall_rays, wall_scan
from vilma.core.messages import Image, PointCloud
from vilma.plant3d.camera import CameraParams
from vilma.plant3d.laser import LaserParams
from vilma.record.world_cdr import (
    CAMERA_INFO,
    COMPRESSED_IMAGE,
    IMAGE,
    LASER_SCAN,
    POINT_CLOUD2,
    SCHEMAS,
    decode_world,
    world_channels,
)
from vilma.record.world_schemas import WorldMessageError

_STORE = get_typestore(Stores.ROS2_HUMBLE)
CAMERA = CameraParams(name="front_left", width=160, height=120, fov_y=90.0)
LASER = LaserParams()


def _written(name: str, msg, sensor=None, **kw) -> dict[str, tuple[bytes, object]]:
    """Topic -> (payload, the message ``mcap_ros2`` decodes from the type's ``ros2msg`` schema)."""
    lay = world_channels(name, sensor, **kw)
    return {t: (p, ros2_decoder(kind, SCHEMAS[kind])(p))
            for (t, kind), p in zip(lay.topics, lay.encode(msg), strict=True)}


def _stamp(g) -> int:
    return g.header.stamp.sec * 10**9 + g.header.stamp.nanosec


def _is_humble(payload: bytes, kind: str) -> bool:
    """Whether ``rosbags``, from ROS 2 Humble's own definition, writes ``payload`` back byte for byte."""
    return _STORE.serialize_cdr(_STORE.deserialize_cdr(payload, kind), kind) == payload


def test_a_raw_image_is_a_sensor_msgs_image_with_camera_info_beside():
    img = red_square(stamp_ns=3_000_000_017, pad=5)
    out = _written("camera/front_left", img, CAMERA)
    assert list(out) == ["camera/front_left", "camera/front_left/camera_info"]
    (payload, g), (info_payload, info) = out.values()
    assert _is_humble(payload, IMAGE) and _is_humble(info_payload, CAMERA_INFO)
    assert (_stamp(g), g.header.frame_id, g.width, g.height, g.encoding, g.is_bigendian, g.step) == (
        3_000_000_017, "front_left", 160, 120, "rgb8", 0, 3 * 160 + 5)
    assert bytes(g.data) == img.data
    f = 60 / math.tan(math.radians(45))  # half the height over tan(half of 90 deg): 60 px
    assert (_stamp(info), info.header.frame_id, info.width, info.height) == (3_000_000_017, "front_left", 160, 120)
    assert list(info.k) == [f, 0, 79.5, 0, f, 59.5, 0, 0, 1] and list(info.r) == [1, 0, 0, 0, 1, 0, 0, 0, 1]
    assert list(info.p) == [f, 0, 79.5, 0, 0, f, 59.5, 0, 0, 0, 1, 0]
    assert info.distortion_model == "plumb_bob" and list(info.d) == [0.0] * 5
    assert decode_world(IMAGE, payload) == img


def test_a_colour_image_is_a_jpeg_compressed_image_read_back_within_tolerance():
    (payload, g), _ = _written("camera/front_left", red_square(), CAMERA, jpeg_quality=90).values()
    assert _is_humble(payload, COMPRESSED_IMAGE) and g.format == "jpeg" and bytes(g.data[:2]) == b"\xff\xd8"
    back = decode_world(COMPRESSED_IMAGE, payload)
    px = np.frombuffer(back.data, np.uint8).reshape(120, 160, 3).astype(int)
    assert (back.width, back.height, back.encoding) == (160, 120, "rgb8")
    assert np.abs(px[:20, :20] - GREY).max() <= 3  # flat grey: JPEG keeps it within a few levels


def test_a_depth_image_is_exact_and_has_no_camera_info():
    depth = depth_image(width=160, height=120)
    out = _written("camera/front_left/depth", depth, CAMERA)
    assert list(out) == ["camera/front_left/depth"]
    payload, g = out["camera/front_left/depth"]
    assert g.encoding == "32FC1" and _is_humble(payload, IMAGE) and decode_world(IMAGE, payload) == depth


def test_a_scan_is_a_laser_scan_and_its_hits_a_point_cloud2():
    scan = wall_scan(stamp_ns=7)
    (s_payload, s), (p_payload, p) = _written("laser", scan, LASER).values()
    assert _is_humble(s_payload, LASER_SCAN) and _is_humble(p_payload, POINT_CLOUD2)
    _, ranges = wall_rays()
    assert (_stamp(s), s.header.frame_id, s.angle_min, s.angle_max) == (7, "laser", np.float32(-math.pi / 2),
                                                                         np.float32(math.pi / 2))
    assert (s.angle_increment, s.time_increment, s.scan_time) == (np.float32(math.radians(1)), 0, np.float32(0.1))
    assert (s.range_min, s.range_max) == (np.float32(0.1), np.float32(30))
    assert np.array_equal(s.ranges, ranges) and len(s.intensities) == 0
    n = int(np.isfinite(ranges).sum())
    assert (_stamp(p), p.header.frame_id, p.height, p.width, p.point_step, p.row_step) == (7, "laser", 1, n, 12, 12 * n)
    assert [(f.name, f.offset, f.datatype, f.count) for f in p.fields] == [("x", 0, 7, 1), ("y", 4, 7, 1),
                                                                            ("z", 8, 7, 1)]
    assert not p.is_bigendian and p.is_dense and bytes(p.data) == scan.points
    assert decode_world(LASER_SCAN, s_payload, p_payload) == scan


def _cloud_dtype(g) -> np.dtype:
    """The points of PointCloud2 ``g`` as a numpy record, from its own fields (PointField datatypes: 4 uint16,
    7 float32), ``point_step`` bytes each."""
    kinds = {4: "<u2", 7: "<f4"}
    return np.dtype({"names": [f.name for f in g.fields], "formats": [kinds[f.datatype] for f in g.fields],
                     "offsets": [f.offset for f in g.fields], "itemsize": g.point_step})


def test_a_multi_layer_scan_is_one_organized_point_cloud2_read_back_bit_for_bit():
    """A row a layer, a column a bearing (scan order: by layer, then by bearing); x, y, z the hit or NaN, range
    the recorded float32 (inf: no hit), ring the layer's index; no LaserScan, no ``laser/points``."""
    scan = layered_scan(stamp_ns=3_000_000_007)
    layers, bearings = len(LAYERED.layers), len(LAYERED.bearings)
    out = _written("laser", scan, LAYERED)
    assert list(out) == ["laser"]
    payload, _ = out["laser"]  # mcap_ros2 decodes it from the recorded schema
    assert _is_humble(payload, POINT_CLOUD2)
    g = _STORE.deserialize_cdr(payload, POINT_CLOUD2)
    assert (_stamp(g), g.header.frame_id, g.height, g.width) == (3_000_000_007, "laser", layers, bearings)
    assert [(f.name, f.offset, f.datatype, f.count) for f in g.fields] == [
        ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1), ("range", 12, 7, 1), ("ring", 16, 4, 1)]
    assert (g.point_step, g.row_step, g.is_bigendian, g.is_dense) == (20, 20 * bearings, False, False)
    assert len(g.data) == g.row_step * g.height
    cloud = np.frombuffer(g.data.tobytes(), _cloud_dtype(g)).reshape(g.height, g.width)
    assert np.array_equal(cloud["ring"], np.repeat(np.arange(layers), bearings).reshape(layers, bearings))
    assert cloud["range"].tobytes() == scan.ranges
    ranges = np.frombuffer(scan.ranges, "<f4").reshape(layers, bearings)
    hit = np.isfinite(ranges)
    assert 0 < hit.sum() < hit.size and not hit[-1].any()  # hits and misses, a layer that sees nothing
    xyz = np.stack([cloud[k] for k in "xyz"], axis=-1)
    assert np.isnan(xyz[~hit]).all()
    assert xyz[hit].astype("<f4").tobytes() == scan.points  # the hits' own bytes, in scan order
    assert np.allclose(xyz[hit], LAYERED.directions()[hit.reshape(-1)] * ranges[hit][:, None])
    assert decode_world(POINT_CLOUD2, payload) == scan


def test_a_one_layer_laser_is_still_a_laser_scan_with_its_points_beside():
    assert world_channels("laser", LASER).topics == (("laser", LASER_SCAN), ("laser/points", POINT_CLOUD2))
    assert world_channels("laser", LAYERED).topics == (("laser", POINT_CLOUD2),)


def test_a_multi_layer_laser_scan_as_recorded_before_still_decodes():
    """All layers' ranges one after another in a LaserScan with the hits beside (serialised by rosbags)."""
    scan = layered_scan(stamp_ns=11)
    header = _STORE.types["std_msgs/msg/Header"](
        stamp=_STORE.types["builtin_interfaces/msg/Time"](sec=0, nanosec=11), frame_id="laser")
    b = LAYERED.bearings
    old = _STORE.types[LASER_SCAN](header=header, angle_min=b[0], angle_max=b[-1], angle_increment=math.radians(15),
                                   time_increment=0.0, scan_time=0.1, range_min=0.1, range_max=30.0,
                                   ranges=np.frombuffer(scan.ranges, "<f4"), intensities=np.zeros(0, np.float32))
    field = _STORE.types["sensor_msgs/msg/PointField"]
    n = len(scan.points) // 12
    points = _STORE.types[POINT_CLOUD2](
        header=header, height=1, width=n, is_bigendian=False, point_step=12, row_step=12 * n, is_dense=True,
        fields=[field(name=k, offset=4 * j, datatype=7, count=1) for j, k in enumerate("xyz")],
        data=np.frombuffer(scan.points, np.uint8))
    s_payload, p_payload = (bytes(_STORE.serialize_cdr(old, LASER_SCAN)),
                            bytes(_STORE.serialize_cdr(points, POINT_CLOUD2)))
    assert decode_world(LASER_SCAN, s_payload, p_payload) == scan


@pytest.mark.parametrize("name, msg, sensor, error", [
    ("laser", wall_scan(), None, "the recorder was not given the laser's parameters, which a LaserScan needs"),
    ("laser", wall_scan(n=11), LASER, "11 ranges, but laser 'laser' casts 181 rays"),
    ("camera/front_left", red_square(width=80), CAMERA, "80x120 px, but camera 'front_left' makes 160x120"),
])
def test_a_message_its_sensor_does_not_make_is_refused_in_one_line(name, msg, sensor, error):
    with pytest.raises(WorldMessageError, match=f"^{error}$"):
        world_channels(name, sensor).encode(msg)


def test_an_image_of_a_camera_the_recorder_does_not_know_has_no_camera_info():
    assert world_channels("camera/rear").topics == (("camera/rear", IMAGE),)


@settings(max_examples=40, deadline=None)
@given(width=st.integers(1, 9), height=st.integers(1, 9), pad=st.integers(0, 5), stamp=st.integers(0, 2**62),
       data=st.data())
def test_raw_images_read_back_exactly_and_a_cut_payload_is_one_clear_error(width, height, pad, stamp, data):
    step = 3 * width + pad
    img = Image(stamp % (2**31 * 10**9), "cam", width, height, "rgb8", step,
                data.draw(st.binary(min_size=height * step, max_size=height * step)))
    (payload,) = world_channels("camera/cam").encode(img)
    assert decode_world(IMAGE, payload) == img
    cut = data.draw(st.integers(0, len(payload) - 1))
    with pytest.raises(ValueError, match=r"^a sensor_msgs/msg/Image message does not decode: [^\n]+$"):
        decode_world(IMAGE, payload[:cut])


@settings(max_examples=60, deadline=None)
@given(ranges=st.lists(st.sampled_from([np.inf, 0.1, 30.0]) | st.floats(0.125, 30, width=32), min_size=11,
                       max_size=11), data=st.data())
def test_scans_read_back_exactly_bit_for_bit(ranges, data):
    """Any float32 bits in the points (NaN payloads too): they are carried, not recomputed."""
    r = np.array(ranges, "<f4")
    hits = 12 * int(np.isfinite(r).sum())
    scan = PointCloud(5, "laser", data.draw(st.binary(min_size=hits, max_size=hits)), r.tobytes())
    payloads = world_channels("laser", LaserParams(fov=10.0)).encode(scan)
    assert decode_world(LASER_SCAN, *payloads) == scan


@settings(max_examples=60, deadline=None)
@given(ranges=st.lists(st.sampled_from([np.inf, np.nan, 0.1, 30.0]) | st.floats(0.125, 30, width=32), min_size=21,
                       max_size=21), data=st.data())
def test_multi_layer_scans_read_back_exactly_bit_for_bit(ranges, data):
    """Any float32 bits in the hits (NaN payloads too), a NaN range a miss: the bytes are carried; and a payload
    cut short is one clear error."""
    r = np.array(ranges, "<f4")
    hits = 12 * int(np.isfinite(r).sum())
    scan = PointCloud(5, "laser", data.draw(st.binary(min_size=hits, max_size=hits)), r.tobytes())
    (payload,) = world_channels("laser", LAYERED).encode(scan)
    assert decode_world(POINT_CLOUD2, payload) == scan
    for cut in (data.draw(st.integers(0, len(payload) - 1)), len(payload) - 1):
        with pytest.raises(ValueError, match=r"^a sensor_msgs/msg/PointCloud2 message does not decode: [^\n]+$"):
            decode_world(POINT_CLOUD2, payload[:cut])
