"""Camera images and laser scans as ROS 2 messages: ROS 2 Humble's bytes, decoded by Foxglove's decoder, read back."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rosbags.typesys import Stores, get_typestore

from tests.record.ros2 import ros2_decoder
from tests.record.world_messages import GREY, depth_image, red_square, wall_rays, wall_scan
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


def test_a_multi_layer_scan_holds_its_layers_one_after_another():
    laser = LaserParams(fov=90.0, resolution=45.0, layers=(-10.0, 0.0, 10.0))
    ranges = np.full(9, np.inf, "<f4")
    scan = PointCloud(1, "laser", b"", ranges.tobytes())
    (s_payload, s), (p_payload, _) = _written("laser", scan, laser).values()
    assert len(s.ranges) == 9 and s.angle_increment == np.float32(math.radians(45))
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
