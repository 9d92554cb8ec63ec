"""The world sensors' mounts as static transforms: their axes in the car's frame, checked by turning vectors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from tests.record.ros2 import ros2_decoder
from vilma.plant3d.camera import CameraParams, camera_axes
from vilma.plant3d.laser import LaserParams
from vilma.record.schemas import FRAME_TRANSFORM, FRAME_TRANSFORM_SCHEMA
from vilma.record.sensor_frames import (
    OPTICAL,
    SensorFrame,
    decode_frame,
    encode_frame,
    quaternion_product,
    sensor_frame,
    sensor_frames,
)

X, Y, Z = np.eye(3)


def rotation_matrix(q) -> np.ndarray:
    """The rotation matrix of unit quaternion ``q`` (x, y, z, w), as textbooks write it."""
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def rz(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def ry(a: float) -> np.ndarray:
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def test_a_laser_frame_is_its_mount_turned_by_its_yaw():
    f = sensor_frame(LaserParams(position=(1.9, 0.0, -0.3), yaw=math.pi / 2), "vilma")
    assert (f.parent, f.child, f.translation) == ("vilma", "laser", (1.9, 0.0, -0.3))
    r = rotation_matrix(f.rotation)
    assert np.allclose(r @ X, Y) and np.allclose(r @ Y, -X) and np.allclose(r @ Z, Z)  # the scan's centre: left


def test_a_camera_frame_is_the_optical_one_z_along_the_axis_x_right_y_down():
    f = sensor_frame(CameraParams(name="front", position=(1.5, 0.2, 0.6), pitch=0.1), "car")
    assert (f.parent, f.child, f.translation) == ("car", "front", (1.5, 0.2, 0.6))
    r = rotation_matrix(f.rotation)
    assert np.allclose(r @ Z, (math.cos(0.1), 0, -math.sin(0.1)))  # forward, 0.1 rad below the horizon
    assert np.allclose(r @ X, (0, -1, 0))  # the image's right: the car's right
    assert np.allclose(r @ Y, (-math.sin(0.1), 0, -math.cos(0.1)))  # the image's down: down, tilted back


@given(st.floats(-math.pi, math.pi), st.floats(-1.5, 1.5))
def test_a_camera_frame_is_rz_ry_then_optical_and_as_the_renderer_points_the_camera(yaw, pitch):
    r = rotation_matrix(sensor_frame(CameraParams(yaw=yaw, pitch=pitch), "vilma").rotation)
    optical = np.column_stack([-Y, -Z, X])  # optical x, y, z in a camera body frame x forward, y left, z up
    assert np.allclose(r, rz(yaw) @ ry(pitch) @ optical)
    right, up, forward = camera_axes(yaw, pitch)  # the MuJoCo camera's axes, whose rows images start at the top
    assert np.allclose(r @ X, right) and np.allclose(r @ Y, -up) and np.allclose(r @ Z, forward)


def test_the_optical_rotation_is_rpy_minus_half_pi_0_minus_half_pi():
    assert np.allclose(rotation_matrix(OPTICAL), rz(-math.pi / 2) @ ry(0) @ np.array(
        [[1, 0, 0], [0, 0, 1], [0, -1, 0]]))  # Rz(-pi/2) Ry(0) Rx(-pi/2)


@given(st.lists(st.floats(-1, 1), min_size=8, max_size=8))
def test_a_quaternion_product_is_the_product_of_the_rotations(v):
    a, b = np.array(v[:4]), np.array(v[4:])
    assume(np.linalg.norm(a) > 0.1 and np.linalg.norm(b) > 0.1)
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    assert np.allclose(rotation_matrix(quaternion_product(a, b)), rotation_matrix(a) @ rotation_matrix(b))


def test_a_sensor_named_as_the_car_has_no_frame_and_no_sensors_none():
    sensors = (CameraParams(name="vilma"), CameraParams(name="rear", yaw=math.pi), LaserParams())
    assert [f.child for f in sensor_frames(sensors, "vilma")] == ["rear", "laser"]
    assert sensor_frames((), "vilma") == ()


def test_a_frame_is_a_foxglove_frame_transform_read_back_as_written():
    frame = sensor_frame(CameraParams(name="front_left", yaw=0.2, pitch=0.3), "vilma")
    payload = encode_frame(frame, 1_500_000_000)
    msg = ros2_decoder(FRAME_TRANSFORM, FRAME_TRANSFORM_SCHEMA)(payload)
    assert (msg.timestamp.sec, msg.timestamp.nanosec, msg.parent_frame_id, msg.child_frame_id) == (
        1, 500_000_000, "vilma", "front_left")
    t, q = msg.translation, msg.rotation
    assert ((t.x, t.y, t.z), (q.x, q.y, q.z, q.w)) == (frame.translation, frame.rotation)
    assert decode_frame(payload) == (1_500_000_000, frame)
    with pytest.raises(ValueError, match="FrameTransform message does not decode"):
        decode_frame(payload[:-8])


def test_a_frame_holds_floats():
    f = sensor_frame(LaserParams(position=(1, 0, 0)), "vilma")
    assert isinstance(f, SensorFrame) and all(type(v) is float for v in (*f.translation, *f.rotation))
