"""The camera against the pinhole model: where a box appears, how wide, the stereo disparity and the depth."""

from __future__ import annotations

import math
import subprocess
import sys
import threading

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.plant3d.camera import MAX_SIDE, CameraParams, CameraSensor, stereo_pair
from vilma.plant3d.plant import MujocoPlant
from vilma.plant3d.world import Box, World
from vilma.vehicle.params import vilma

CAR = vilma()
RED = (1.0, 0.0, 0.0, 1.0)
THIN = 0.02
"""Half thickness of the plates the camera looks at [m]."""
SMALL = {"width": 160, "height": 120}


def camera_at(p: CameraParams) -> np.ndarray:
    """The optical centre in the world of a car at rest at the origin (chassis level at its CG height) [m]."""
    return np.add(p.position, (0.0, 0.0, CAR.suspension.cg_height))


def project(p: CameraParams, point: tuple[float, float, float]) -> tuple[float, float, float]:
    """Pinhole projection of a world point: ``(column, row)`` of the pixel centre holding it, from the top-left
    pixel, and its distance along the optical axis [m]."""
    cy, sy, cp, sp = math.cos(p.yaw), math.sin(p.yaw), math.cos(p.pitch), math.sin(p.pitch)
    forward = np.array([cp * cy, cp * sy, -sp])
    right = np.array([sy, -cy, 0.0])
    up = np.cross(right, forward)
    rel = np.asarray(point) - camera_at(p)
    f = p.height / 2 / math.tan(math.radians(p.fov_y) / 2)
    z = rel @ forward
    return p.width / 2 + f * (rel @ right) / z - 0.5, p.height / 2 - f * (rel @ up) / z - 0.5, z


def focal(p: CameraParams) -> float:
    return p.height / 2 / math.tan(math.radians(p.fov_y) / 2)


def capture(params: CameraParams, *boxes: Box) -> dict:
    sensor = CameraSensor(params)
    plant = MujocoPlant(CAR, World(boxes=boxes), cameras=sensor.mjcf())
    sensor.attach(plant)
    try:
        return sensor.capture(1_000)
    finally:
        sensor.close()


def rgb(out: dict, name: str) -> np.ndarray:
    image = out[f"camera/{name}"]
    return np.frombuffer(image.data, np.uint8).reshape(image.height, image.width, 3)


def depth(out: dict, name: str) -> np.ndarray:
    image = out[f"camera/{name}/depth"]
    return np.frombuffer(image.data, "<f4").reshape(image.height, image.width)


def red(image: np.ndarray) -> np.ndarray:
    """Pixels whose hue is red, whatever the shading: red well above green and blue."""
    r, g, b = (image[..., i].astype(int) for i in range(3))
    return (r > 40) & (r > 2 * g) & (r > 2 * b)


def centroid(mask: np.ndarray) -> tuple[float, float]:
    rows, cols = np.nonzero(mask)
    assert len(rows), "nothing red in the image"
    return float(cols.mean()), float(rows.mean())


def plate(centre: tuple[float, float, float], half_width: float, half_height: float, yaw: float = 0.0) -> Box:
    """A thin red plate facing the direction ``yaw`` [rad], centred on ``centre`` [m]."""
    return Box(pos=centre, size=(THIN, half_width, half_height), yaw=yaw, rgba=RED)


def test_a_plate_ahead_appears_where_the_pinhole_projection_puts_it_at_640x480():
    params = CameraParams()
    eye = camera_at(params)
    centre = (12.0, 0.8, eye[2] + 0.8)
    out = capture(params, plate(centre, 0.6, 0.5))
    image = out["camera/front"]
    assert (image.stamp_ns, image.frame_id, image.encoding) == (1_000, "front", "rgb8")
    assert (image.width, image.height, image.step, len(image.data)) == (640, 480, 3 * 640, 640 * 480 * 3)
    mask = red(rgb(out, "front"))
    near_face = (centre[0] - THIN, centre[1], centre[2])
    u, v, z = project(params, near_face)
    assert centroid(mask) == pytest.approx((u, v), abs=1.5)
    row = mask[round(v)]
    assert row.sum() == pytest.approx(focal(params) * 1.2 / z, abs=2)  # the plate is 1.2 m wide
    assert mask.sum(axis=0).max() == pytest.approx(focal(params) * 1.0 / z, abs=2)


def test_a_plate_on_the_left_appears_on_the_left():
    params = CameraParams(**SMALL)
    eye = camera_at(params)
    centre = (10.0, 4.0, eye[2] + 0.5)
    u, v, _ = project(params, (centre[0] - THIN, *centre[1:]))
    col, row = centroid(red(rgb(capture(params, plate(centre, 0.5, 0.5)), "front")))
    assert col < params.width / 2 - 10
    assert (col, row) == pytest.approx((u, v), abs=1.5)


def test_yaw_and_pitch_turn_the_view_as_the_projection_says():
    params = CameraParams(yaw=0.4, pitch=0.15, **SMALL)
    eye = camera_at(params)
    bearing, distance = 0.3, 9.0  # the plate right of the optical axis and above it, facing the camera
    centre = (eye[0] + distance * math.cos(bearing), eye[1] + distance * math.sin(bearing), eye[2] - 0.5)
    u, v, _ = project(params, centre)
    col, row = centroid(red(rgb(capture(params, plate(centre, 0.4, 0.4, yaw=bearing)), "front")))
    assert (col, row) == pytest.approx((u, v), abs=2)
    assert col > params.width / 2 and row < params.height / 2


def test_stereo_disparity_is_focal_length_times_baseline_over_depth():
    left, right = stereo_pair(baseline=0.3, fov_y=30.0, **SMALL)
    assert (left.name, right.name) == ("front_left", "front_right")
    assert left.position[1] - right.position[1] == pytest.approx(0.3)
    eye = camera_at(left)
    centre = (8.0, 0.0, eye[2] + 0.3)
    sensors = [CameraSensor(p) for p in (left, right)]
    plant = MujocoPlant(CAR, World(boxes=(plate(centre, 0.4, 0.4),)), cameras="".join(s.mjcf() for s in sensors))
    cols = []
    for sensor in sensors:
        sensor.attach(plant)
        cols.append(centroid(red(rgb(sensor.capture(0), sensor.name)))[0])
        sensor.close()
    z = centre[0] - THIN - eye[0]
    assert cols[0] > left.width / 2 > cols[1]  # the plate is to the right of the left eye's axis
    assert cols[0] - cols[1] == pytest.approx(focal(left) * 0.3 / z, abs=1)


def test_depth_is_the_distance_along_the_optical_axis_and_inf_where_nothing_is():
    params = CameraParams(depth=True, **SMALL)
    eye = camera_at(params)
    out = capture(params, plate((8.0, 0.0, eye[2]), 0.5, 0.5))
    metres = depth(out, "front")
    image = out["camera/front/depth"]
    assert (image.encoding, image.step, image.frame_id) == ("32FC1", 4 * params.width, "front")
    centre = params.height // 2, params.width // 2
    assert metres[centre] == pytest.approx(8.0 - THIN - eye[0], abs=0.01)
    assert red(rgb(out, "front"))[centre]
    assert np.isinf(metres[0]).all()  # the sky
    row = params.height // 2 + 10  # ground beside the plate: depth = height * f / (pixel centre below the axis)
    assert metres[row, 10] == pytest.approx(eye[2] * focal(params) / (row + 0.5 - params.height / 2), rel=1e-3)


def test_nothing_beyond_far_is_drawn():
    params = CameraParams(depth=True, far=5.0, **SMALL)
    eye = camera_at(params)
    out = capture(params, plate((8.0, 0.0, eye[2] + 0.5), 0.5, 0.5))
    assert not red(rgb(out, "front")).any()
    assert np.isinf(depth(out, "front")[: params.height // 2]).all()


def test_a_camera_reattached_to_a_rebuilt_plant_sees_the_new_world_from_another_thread():
    params = CameraParams(**SMALL)
    eye = camera_at(params)
    sensor = CameraSensor(params)
    sensor.attach(MujocoPlant(CAR, World(), cameras=sensor.mjcf()))
    assert not red(rgb(sensor.capture(0), "front")).any()
    sensor.attach(MujocoPlant(CAR, World(boxes=(plate((10.0, 0.0, eye[2] + 0.5), 0.5, 0.5),)),
                              cameras=sensor.mjcf()))
    here = sensor.capture(0)
    there: list[dict] = []
    worker = threading.Thread(target=lambda: there.append(sensor.capture(0)))
    worker.start()
    worker.join(timeout=30)
    sensor.close()
    assert red(rgb(here, "front")).any()
    assert there[0]["camera/front"].data == here["camera/front"].data


def test_capture_before_attach_is_an_error():
    with pytest.raises(RuntimeError, match="before attach"):
        CameraSensor(CameraParams()).capture(0)


def test_the_parameters_import_without_mujoco():
    code = "import sys, vilma.plant3d.camera, vilma.plant3d.laser; assert 'mujoco' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"name": "front cam"}, "name must be a word"),
    ({"width": 0}, "width must be a whole number of pixels in 1..4096"),
    ({"width": 100_000}, "width must be a whole number of pixels in 1..4096"),
    ({"height": 480.0}, "height must be a whole number of pixels"),
    ({"fov_y": 180.0}, "fov_y must be between 0 and 180"),
    ({"pitch": math.pi / 2}, "pitch must be between"),
    ({"position": (1.0, 0.0)}, "position must be three finite numbers"),
    ({"near": 1.0, "far": 0.5}, "0 < near < far"),
    ({"rate_hz": 0.0}, "rate_hz must be a positive number"),
])
def test_bad_parameters_say_what_to_fix(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CameraParams(**kwargs)


def test_a_stereo_pair_needs_a_positive_baseline():
    with pytest.raises(ValueError, match="baseline must be a positive number"):
        stereo_pair(baseline=0.0)


@given(st.integers(-3, 3) | st.integers(MAX_SIDE - 2, MAX_SIDE + 2), st.floats(-200, 200, allow_nan=False))
def test_size_and_field_of_view_are_valid_exactly_when_in_range(width, fov):
    valid = 0 < width <= MAX_SIDE and 0 < fov < 180
    if valid:
        assert CameraParams(width=width, fov_y=fov).width == width
    else:
        with pytest.raises(ValueError, match=r"width|fov_y"):
            CameraParams(width=width, fov_y=fov)
