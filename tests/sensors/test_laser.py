"""The flat-ground laser against geometry: rays from the mount meet the obstacles' outlines where straight lines
meet rectangles."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from vilma.core.messages import PointCloud
from vilma.plant3d.laser import LaserParams
from vilma.record.world_schemas import cloud_problem
from vilma.sensors import SensorSuite
from vilma.sensors.base import Samples, sensor_rng
from vilma.sensors.laser import PlanarLaser
from vilma.sensors.scene import Scene
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import VehicleState
from vilma.world.traffic import Traffic

MOUNT = 1.9  # the laser's default mount ahead of the centre of mass [m]
L, W = 4.0, 2.0  # a box's length and width [m]
BOX = np.array([[L / 2, -W / 2], [L / 2, W / 2], [-L / 2, W / 2], [-L / 2, -W / 2]])


def box(*poses, static=True, dt=0.1, present=None) -> Scene:
    """One box at the poses (x, y, yaw, speed) of the time steps 0, 1, ..."""
    states = np.array([poses], float)
    return Scene(np.array([7]), np.array([static]), BOX[None], states,
                 np.ones(states.shape[:2], bool) if present is None else np.array([present]), dt)


def scans(scene: Scene, n=1, car=VehicleState(), stamp_ns=0, **laser) -> list[PointCloud]:
    """``n`` scans from ``car`` at sim time ``stamp_ns`` [ns]."""
    p = LaserParams(**laser)
    sensor = PlanarLaser(name="laser", mount=(*p.position[:2], p.yaw), bearings=p.bearings, min_range=p.min_range,
                         max_range=p.max_range, noise=p.range_noise, rate_hz=p.rate_hz, scene=scene)
    sensor.reset(sensor_rng(0, "laser"))
    z = np.repeat(car.to_array()[None], n, 0)
    out = sensor.scan(Samples(np.arange(n), z, np.zeros((n, 6))), np.full(n, stamp_ns))
    assert all(cloud_problem(m) is None for m in out)  # scans the recorders take as the 3D laser's
    return out


def scan(scene: Scene, car=VehicleState(), stamp_ns=0, **laser) -> tuple[np.ndarray, np.ndarray]:
    """The ranges [m] and hit points (hits, 3) [m] of one scan from ``car`` at sim time ``stamp_ns`` [ns]."""
    (msg,) = scans(scene, 1, car, stamp_ns, **laser)
    return np.frombuffer(msg.ranges, "<f4").astype(float), np.frombuffer(msg.points, "<f4").reshape(-1, 3)


def test_a_box_straight_ahead_is_at_its_distance_less_half_its_length_on_the_centre_ray():
    d = 20.0
    ranges, points = scan(box((MOUNT + d, 0, 0, 0)))
    bearings = LaserParams().bearings
    centre = len(bearings) // 2
    assert bearings[centre] == 0 and ranges[centre] == pytest.approx(d - L / 2, abs=1e-5)
    # a ray at bearing b meets the near face x = d - L/2 within |y| <= W/2, at (d - L/2) / cos b; the faces behind
    # it are hidden, and the other rays miss (inf, as the 3D laser has it)
    near = (d - L / 2) * np.abs(np.tan(bearings)) <= W / 2
    np.testing.assert_allclose(ranges[near], (d - L / 2) / np.cos(bearings[near]), rtol=1e-6)
    assert np.isinf(ranges[~near]).all() and near.sum() == 7  # 0, +-1, +-2, +-3 deg: atan(1 / 18) = 3.2 deg
    np.testing.assert_allclose(points[near.cumsum()[centre] - 1], [d - L / 2, 0, 0], atol=1e-5)


def test_the_scan_turns_with_the_car():
    yaw, d = 2.0, 10.0
    x, y = (MOUNT + d) * math.cos(yaw), (MOUNT + d) * math.sin(yaw)
    ranges, _ = scan(box((x, y, yaw + 0.3, 0)), VehicleState(yaw=yaw))
    # turned by 0.3 rad, the box's centre is still on the ray, which leaves the box by its front face L/2 ahead of
    # the centre along the box's axis (at y = L/2 tan 0.3 = 0.62 m < W/2)
    assert ranges[90] == pytest.approx(d - L / 2 / math.cos(0.3), abs=1e-5)
    ranges, _ = scan(box((x, y, yaw, 0)), VehicleState(yaw=yaw))
    assert ranges[90] == pytest.approx(d - L / 2, abs=1e-5)


def test_a_box_behind_is_not_seen_in_a_forward_field_of_view_but_in_a_full_circle():
    d = 20.0
    behind = box((MOUNT - d, 0, 0, 0))
    assert np.isinf(scan(behind)[0]).all()
    ranges, _ = scan(behind, fov=360.0)
    bearings = LaserParams(fov=360.0).bearings
    assert bearings[0] == -math.pi and ranges[0] == pytest.approx(d - L / 2, abs=1e-5)


def test_an_empty_world_and_hits_out_of_range_give_no_hits():
    assert np.isinf(scan(Scene.of(None))[0]).all()
    assert np.isinf(scan(box((MOUNT + 31 + L / 2, 0, 0, 0)))[0]).all()  # beyond the 30 m max range
    assert np.isinf(scan(box((MOUNT + 1 + L / 2, 0, 0, 0)), min_range=2.0)[0][90])  # nearer than min_range


def test_a_moving_box_is_where_its_recording_puts_it_at_the_scan_time():
    v, dt = 10.0, 0.1  # 10 m/s along x, recorded every 0.1 s
    moving = box(*((MOUNT + 10 + v * k * dt, 0, 0, v) for k in range(11)), static=False, dt=dt)
    for t in (0.0, 0.25, 1.0):
        assert scan(moving, stamp_ns=round(t * 1e9))[0][90] == pytest.approx(10 + v * t - L / 2, abs=1e-5)
    assert np.isinf(scan(moving, stamp_ns=1_100_000_000)[0]).all()  # past its recording: gone
    later = dataclasses.replace(moving, t0=0.5)  # the planning problem starts at the recording's 0.5 s
    assert scan(later)[0][90] == pytest.approx(10 + v * 0.5 - L / 2, abs=1e-5)


def test_an_absent_obstacle_is_not_seen():
    assert np.isinf(scan(box((MOUNT + 10, 0, 0, 0), (MOUNT + 10, 0, 0, 0), static=False,
                             present=[False, False]))[0]).all()


def test_ranges_have_the_given_noise_and_misses_stay_misses():
    d, sigma, n = 20.0, 0.05, 4000
    got = np.array([np.frombuffer(m.ranges, "<f4") for m in scans(box((MOUNT + d, 0, 0, 0)), n, range_noise=sigma)])
    centre = got[:, 90]
    assert abs(centre.mean() - (d - L / 2)) < 4 * sigma / math.sqrt(n)  # within 4 standard errors
    assert abs(centre.std(ddof=1) - sigma) < 4 * sigma / math.sqrt(2 * n)
    assert np.isinf(got[:, :80]).all()  # the noise is on the hits only


def test_the_simulator_scans_the_traffic_at_the_laser_rate_on_flat_ground():
    """The single-track car coasting at 10 m/s towards a box 40 m ahead: each scan's centre range is the gap."""
    b = box((MOUNT + 40 + L / 2, 0, 0, 0))
    traffic = Traffic(ids=b.ids, static=b.static, outline=b.outline, states=b.states, present=b.present, dt=b.dt)
    sim = Simulator(SimConfig(laser=LaserParams(max_range=60.0), sensors=SensorSuite.none(), traffic=traffic,
                              initial=VehicleState(vx=10.0)))
    xs = []
    for _ in range(10):
        sim.run_for(0.1)
        xs.append(sim.state.x)
    scans = sim.take_captures()
    assert [s[0] for s in scans] == ["laser"] * 10
    assert [s[1].stamp_ns for s in scans] == [k * 100_000_000 for k in range(1, 11)]
    gaps = [float(np.frombuffer(s[1].ranges, "<f4")[90]) for s in scans]
    np.testing.assert_allclose(gaps, 40 - np.array(xs), atol=1e-4)
    assert xs[-1] > 9  # it drove: the gap shrank by the distance driven


def test_a_laser_on_flat_ground_has_one_layer_and_only_it_has_noise():
    with pytest.raises(ValueError, match="one layer"):
        SimConfig(laser=LaserParams(layers=(0.0, 5.0)))
    with pytest.raises(ValueError, match="exact: remove the laser's range_noise"):
        SimConfig(model="mujoco", laser=LaserParams(range_noise=0.1))
    with pytest.raises(ValueError, match="range_noise must be a number >= 0"):
        LaserParams(range_noise=-1.0)
