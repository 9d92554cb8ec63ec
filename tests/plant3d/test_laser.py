"""The laser scanner against geometry: walls at known distances, the ground below a tilted layer, the car unseen."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.plant3d.laser import MAX_RAYS, LaserParams, LaserSensor
from vilma.plant3d.plant import MujocoPlant
from vilma.plant3d.world import Box, World
from vilma.vehicle.params import vilma

CAR = vilma()
HALF = 0.05
"""Half thickness of the walls [m]."""


def mount(p: LaserParams) -> np.ndarray:
    """The laser in the world of a car at rest at the origin (chassis level at its CG height) [m]."""
    return np.add(p.position, (0.0, 0.0, CAR.suspension.cg_height))


def bearings(p: LaserParams) -> np.ndarray:
    """The rays of a layer from the right end of the scan to the left, ``resolution`` apart [rad]."""
    n = round(p.fov / p.resolution) + (0 if p.fov == 360 else 1)
    return np.radians(-p.fov / 2 + p.resolution * np.arange(n))


def scan(params: LaserParams, *boxes: Box) -> tuple[np.ndarray, np.ndarray, MujocoPlant]:
    """Ranges and points of one scan, and the plant it was taken in."""
    sensor = LaserSensor(params)
    plant = MujocoPlant(CAR, World(boxes=boxes), cameras=sensor.mjcf())
    sensor.attach(plant)
    cloud = sensor.capture(7)["laser"]
    sensor.close()
    assert (cloud.stamp_ns, cloud.frame_id) == (7, params.name)
    return np.frombuffer(cloud.ranges, "<f4"), np.frombuffer(cloud.points, "<f4").reshape(-1, 3), plant


def points_along_rays(ranges: np.ndarray, points: np.ndarray, bearing: np.ndarray, elevation: np.ndarray) -> None:
    hit = np.isfinite(ranges)
    rays = np.column_stack([np.cos(elevation) * np.cos(bearing), np.cos(elevation) * np.sin(bearing),
                            np.sin(elevation)])
    assert points == pytest.approx(rays[hit] * ranges[hit, None], abs=1e-4)


def test_a_wall_ahead_is_hit_at_its_distance_over_the_cosine_of_the_bearing():
    params = LaserParams()
    x = mount(params)[0] + 8.0 + HALF  # the wall's near face 8 m ahead of the laser
    ranges, points, _ = scan(params, Box(pos=(x, 0.0, 1.0), size=(HALF, 50.0, 1.0)))
    a = bearings(params)
    assert len(ranges) == 181
    expected = 8.0 / np.cos(a)
    reached = expected <= params.max_range
    assert ranges[reached] == pytest.approx(expected[reached], abs=0.01)
    assert np.isinf(ranges[~reached]).all() and (~reached).sum() == 2 * 16  # beyond acos(8 / 30) = 74.5 deg
    points_along_rays(ranges, points, a, np.zeros_like(a))


def test_a_yawed_laser_scans_counter_clockwise_from_its_right():
    params = LaserParams(yaw=math.pi / 4)
    y = mount(params)[1] + 6.0 + HALF  # a wall along the car, 6 m to the left of the laser
    ranges, points, _ = scan(params, Box(pos=(0.0, y, 1.0), size=(50.0, HALF, 1.0)))
    a = bearings(params)
    heading = params.yaw + a
    sin = np.sin(heading)
    expected = np.full_like(sin, np.inf)
    expected[sin > 1e-9] = 6.0 / sin[sin > 1e-9]  # rays heading away from the wall never meet it
    reached = expected <= params.max_range
    assert ranges[reached] == pytest.approx(expected[reached], abs=0.01)
    assert np.isinf(ranges[~reached]).all()
    assert np.isinf(ranges[0]) and np.isfinite(ranges[-1])  # the first ray looks right of the car: nothing there
    points_along_rays(ranges, points, a, np.zeros_like(a))


def test_hits_nearer_than_min_range_are_not_reported():
    params = LaserParams(min_range=1.2)
    x = mount(params)[0] + 0.5 + HALF
    ranges, _, _ = scan(params, Box(pos=(x, 0.0, 1.0), size=(HALF, 50.0, 1.0)))
    expected = 0.5 / np.cos(bearings(params))
    near = expected < params.min_range
    assert near.sum() == 2 * 65 + 1  # within acos(0.5 / 1.2) = 65.4 deg of the wall's normal
    assert np.isinf(ranges[near]).all()
    far = ~near & (expected <= params.max_range)
    assert ranges[far] == pytest.approx(expected[far], abs=0.01)


def test_a_horizontal_scan_at_wheel_height_does_not_see_the_car():
    params = LaserParams(position=(0.0, 0.0, CAR.wheel_radius - CAR.suspension.cg_height), fov=360.0)
    ranges, points, plant = scan(params)
    assert np.isinf(ranges).all() and points.size == 0
    m, d = plant.model, plant.data
    towards_wheel = d.xpos[m.body("wheel_fl").id] - mount(params)
    hit = np.array([-1], np.int32)
    mujoco.mj_ray(m, d, mount(params), towards_wheel / np.linalg.norm(towards_wheel), None, 1, -1, hit)
    assert m.body(m.geom_bodyid[hit[0]]).name == "wheel_fl"  # unless the car's geom group is masked


def test_layers_pointing_down_hit_the_ground_at_height_over_the_sine_of_the_elevation():
    params = LaserParams(position=(0.0, 0.0, 0.6), fov=360.0, resolution=5.0, layers=(-20.0, -45.0))
    ranges, points, plant = scan(params)
    height = mount(params)[2]
    n = 72
    assert len(ranges) == 2 * n
    assert ranges[:n] == pytest.approx(np.full(n, height / math.sin(math.radians(20))), abs=0.01)
    assert ranges[n:] == pytest.approx(np.full(n, height / math.sin(math.radians(45))), abs=0.01)
    assert points[:, 2] == pytest.approx(np.full(2 * n, -height), abs=0.01)
    a = np.tile(bearings(params), 2)
    points_along_rays(ranges, points, a, np.radians(np.repeat([-20.0, -45.0], n)))
    m, d = plant.model, plant.data
    hit = np.array([-1], np.int32)
    down = np.array([math.cos(math.radians(20)), 0.0, -math.sin(math.radians(20))])
    mujoco.mj_ray(m, d, mount(params), down, None, 1, -1, hit)
    assert m.geom(hit[0]).name == "body"  # the forward ray of the upper layer crosses the car's roof


def test_capture_before_attach_is_an_error():
    with pytest.raises(RuntimeError, match="before attach"):
        LaserSensor(LaserParams()).capture(0)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"name": ""}, "name must be a word"),
    ({"fov": 400.0}, r"fov must be in \(0, 360\]"),
    ({"resolution": 0.0}, "resolution must be in"),
    ({"fov": 180.0, "resolution": 0.7}, "whole number of resolution steps"),
    ({"layers": ()}, "layers must be a non-empty tuple"),
    ({"layers": (0.0, 95.0)}, r"elevations in \[-90, 90\]"),
    ({"min_range": 5.0, "max_range": 2.0}, "0 <= min_range < max_range"),
    ({"position": (0.0, math.nan, 0.0)}, "position must be three finite numbers"),
    ({"fov": 360.0, "resolution": 1e-6}, r"casts 3\.6e\+08 rays a scan \(3\.6e\+08 a layer\), more than 300000"),
])
def test_bad_parameters_say_what_to_fix(kwargs, message):
    with pytest.raises(ValueError, match=message):
        LaserParams(**kwargs)


def test_a_scan_casts_at_most_max_rays():
    """A 64-layer Velodyne HDL-64E at 0.08 deg, 288,000 rays a turn, fits; twice its layers do not."""
    layers = tuple(-24.8 + 26.8 * i / 63 for i in range(64))
    assert len(LaserParams(fov=360.0, resolution=0.08, layers=layers).bearings) * 64 == 288_000 <= MAX_RAYS
    with pytest.raises(ValueError, match=f"casts 5.76e\\+05 rays a scan \\(4500 a layer\\), more than {MAX_RAYS}"):
        LaserParams(fov=360.0, resolution=0.08, layers=layers * 2)


@given(st.integers(1, 720), st.sampled_from([0.25, 0.5, 1.0, 2.0]))
def test_a_field_of_view_of_whole_steps_gives_one_ray_per_step_plus_the_last(steps, resolution):
    fov = steps * resolution
    if fov > 360:
        with pytest.raises(ValueError, match="fov must be in"):
            LaserParams(fov=fov, resolution=resolution)
        return
    params = LaserParams(fov=fov, resolution=resolution, layers=(0.0, 10.0))
    rays = params.directions()
    per_layer = steps if fov == 360 else steps + 1
    assert rays.shape == (2 * per_layer, 3)
    assert np.linalg.norm(rays, axis=1) == pytest.approx(np.ones(2 * per_layer))
    assert math.degrees(math.atan2(rays[0, 1], rays[0, 0])) == pytest.approx(-fov / 2)
