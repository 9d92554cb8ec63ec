"""Camera images and laser scans as Foxglove JSON: well-formed schemas and messages, base64 bytes, read back."""

from __future__ import annotations

import base64
import io
import json
import re

import numpy as np
import pytest
from PIL import Image as PILImage

from tests.record.world_messages import GREY, SQUARE, depth_image, red_square, red_square_pixels, wall_scan
from vilma.core.messages import Image, PointCloud, Pose
from vilma.record.world_schemas import (
    COMPRESSED_IMAGE,
    POINT_CLOUD,
    RAW_IMAGE,
    WorldMessageError,
    check_jpeg_quality,
    check_world_topics,
    cloud_problem,
    compressed_image,
    decode_world,
    image_problem,
    world_layout,
)

JPEG_TOLERANCE = 12
"""Grey levels a JPEG (quality 90) may move a flat colour by, away from its edges."""


def _pixels(img: Image) -> np.ndarray:
    return np.frombuffer(img.data, np.uint8).reshape(img.height, img.step)[:, :3 * img.width].reshape(
        img.height, img.width, 3)


def _time_ns(obj: dict) -> int:
    return obj["timestamp"]["sec"] * 10**9 + obj["timestamp"]["nsec"]


def test_colour_image_is_a_foxglove_compressed_jpeg_read_back_within_tolerance():
    img = red_square(stamp_ns=3_250_000_001)
    lay = world_layout("camera/front_left")
    payload = lay.encode(img)
    obj = json.loads(payload)
    assert lay.schema_name == COMPRESSED_IMAGE
    assert obj["format"] == "jpeg" and obj["frame_id"] == "front_left"
    assert _time_ns(obj) == obj["stamp_ns"] == 3_250_000_001
    jpeg = base64.b64decode(obj["data"], validate=True)
    assert jpeg[:2] == b"\xff\xd8" and compressed_image(payload) == (3_250_000_001, "front_left", "jpeg", jpeg)
    with PILImage.open(io.BytesIO(jpeg)) as f:
        assert f.format == "JPEG" and f.size == (160, 120)
    back = decode_world(COMPRESSED_IMAGE, payload)
    assert (back.stamp_ns, back.width, back.height, back.encoding, back.step) == (3_250_000_001, 160, 120, "rgb8", 480)
    got = _pixels(back).astype(int)
    x, y, w, h = SQUARE
    inner = got[y + 8:y + h - 8, x + 8:x + w - 8]  # JPEG smears colour over 8-16 px blocks at edges
    assert np.abs(inner - (255, 0, 0)).max() <= JPEG_TOLERANCE
    assert np.abs(got[:y - 8] - GREY).max() <= JPEG_TOLERANCE and np.abs(got[y + h + 8:] - GREY).max() <= JPEG_TOLERANCE


def test_padded_rows_are_stripped_before_jpeg():
    back = decode_world(COMPRESSED_IMAGE, world_layout("camera/a").encode(red_square(pad=16)))
    assert back.step == 3 * back.width
    assert np.abs(_pixels(back).astype(int) - red_square_pixels()).mean() < 3


@pytest.mark.parametrize("name, img", [("camera/front_left", red_square(pad=5)),
                                       ("camera/front_left/depth", depth_image())])
def test_raw_images_read_back_exactly(name, img):
    lay = world_layout(name, jpeg_quality=None)
    obj = json.loads(lay.encode(img))
    assert lay.schema_name == RAW_IMAGE
    assert {k: obj[k] for k in ("frame_id", "width", "height", "encoding", "step")} == {
        "frame_id": img.frame_id, "width": img.width, "height": img.height, "encoding": img.encoding,
        "step": img.step}
    assert base64.b64decode(obj["data"], validate=True) == img.data and _time_ns(obj) == img.stamp_ns
    assert decode_world(RAW_IMAGE, lay.encode(img)) == img


def test_depth_is_raw_whatever_the_jpeg_setting_and_keeps_inf():
    lay = world_layout("camera/front_left/depth", jpeg_quality=50)
    back = decode_world(lay.schema_name, lay.encode(depth_image()))
    d = np.frombuffer(back.data, "<f4").reshape(48, 64)
    assert lay.schema_name == RAW_IMAGE and np.isinf(d[:12]).all() and d[-1, 0] == 2.0 and d[12, 5] == 10.75


def test_laser_is_a_foxglove_point_cloud_with_its_ranges_beside():
    scan = wall_scan(stamp_ns=42)
    lay = world_layout("laser")
    obj = json.loads(lay.encode(scan))
    assert lay.schema_name == POINT_CLOUD and obj["frame_id"] == "laser" and _time_ns(obj) == 42
    assert obj["pose"] == {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                           "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
    assert obj["point_stride"] == 12
    assert obj["fields"] == [{"name": "x", "offset": 0, "type": 7}, {"name": "y", "offset": 4, "type": 7},
                             {"name": "z", "offset": 8, "type": 7}]
    points = np.frombuffer(base64.b64decode(obj["data"], validate=True), "<f4").reshape(-1, 3)
    assert len(points) == 79 and np.allclose(points[:, 0], 5.0) and np.all(points[:, 2] == 0)
    assert base64.b64decode(obj["ranges"]) == scan.ranges
    assert decode_world(POINT_CLOUD, lay.encode(scan)) == scan


@pytest.mark.parametrize("name, quality", [("camera/a", 90), ("camera/a", None), ("laser", None)])
def test_schemas_are_json_schemas_with_base64_bytes(name, quality):
    lay = world_layout(name, quality)
    schema = json.loads(lay.schema)
    assert schema["title"] == lay.schema_name and schema["type"] == "object"
    props = schema["properties"]
    assert props["data"]["type"] == "string" and props["data"]["contentEncoding"] == "base64"
    assert set(props["timestamp"]["properties"]) == {"sec", "nsec"} and "frame_id" in props
    assert set(schema["required"]) <= set(props)


@pytest.mark.parametrize("msg, says", [
    (Image(1, "c", 4, 2, "rgb8", 12, b"\0" * 23), "23 bytes of data, not height 2 x step 12 = 24"),
    (Image(1, "c", 4, 2, "rgb8", 10, b"\0" * 20), "step 10 bytes is less than width 4 x 3 bytes"),
    (Image(1, "c", 4, 2, "bgr8", 12, b"\0" * 24), "encoding 'bgr8' is not one of rgb8, 32FC1"),
    (Image(1, "c", 0, 2, "rgb8", 12, b"\0" * 24), "size 0x2 px is empty"),
    (Pose(1, 0, 0, 0, 0, 0, 0), "a Pose, not an Image"),
])
def test_malformed_images_are_refused_with_what_is_wrong(msg, says):
    assert image_problem(msg) == says
    for q in (90, None):
        with pytest.raises(WorldMessageError, match=re.escape(says)):
            world_layout("camera/c", q).encode(msg)


def test_an_image_on_the_wrong_kind_of_topic_is_refused():
    with pytest.raises(WorldMessageError, match="encoding 32FC1, but this topic carries rgb8"):
        world_layout("camera/c").encode(depth_image())
    with pytest.raises(WorldMessageError, match="carries 32FC1"):
        world_layout("camera/c/depth").encode(red_square())


def test_malformed_scans_are_refused():
    good = wall_scan()
    assert cloud_problem(good) is None
    assert "not whole float32 xyz" in cloud_problem(PointCloud(1, "laser", good.points[:-1], good.ranges))
    assert cloud_problem(PointCloud(1, "laser", good.points[:-12], good.ranges)) == "78 points for 79 finite ranges"
    with pytest.raises(WorldMessageError, match="78 points"):
        world_layout("laser").encode(PointCloud(1, "laser", good.points[:-12], good.ranges))


def test_world_topic_names_and_jpeg_quality_are_checked():
    assert check_world_topics(["laser", "camera/a", "camera/a/depth"]) == ("laser", "camera/a", "camera/a/depth")
    for bad in ("pose", "camera", "camera/a/b", "lidar", "camera//depth"):
        with pytest.raises(ValueError, match="not a camera or laser topic"):
            check_world_topics([bad])
    assert check_jpeg_quality(None) is None and check_jpeg_quality(75) == 75
    for bad in (0, 96, 90.0, True):
        with pytest.raises(ValueError, match=r"JPEG quality must be 1\.\.95"):
            check_jpeg_quality(bad)


def test_a_corrupt_payload_is_one_value_error():
    with pytest.raises(ValueError, match="does not decode"):
        decode_world(COMPRESSED_IMAGE, b'{"timestamp": 1}')
    bad_jpeg = json.loads(world_layout("camera/a").encode(red_square()))
    bad_jpeg["data"] = base64.b64encode(b"not a jpeg").decode()
    with pytest.raises(ValueError, match="does not decode"):
        decode_world(COMPRESSED_IMAGE, json.dumps(bad_jpeg).encode())
