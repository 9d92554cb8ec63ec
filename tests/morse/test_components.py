"""vilma readings as MORSE component dicts, and MORSE actuator messages as vilma commands."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from tests.record.world_messages import WALL, wall_rays, wall_scan
from vilma.core.messages import Imu, Longitudinal, Odometry, PointCloud, Pose
from vilma.morse.components import (
    COMPONENTS,
    EARTH_FIELD_ENU,
    LASER_RANGE,
    STEER_BRAKE_UNIT,
    STEER_FORCE_UNIT,
    WORLD_COMPONENTS,
    CommandValueError,
    OriginalCar,
    SensorMapper,
    components,
    laser_dict,
    motion_command,
    steer_force_command,
)
from vilma.sensors.base import Readings
from vilma.vehicle.params import vilma


def _imu(yaw: float) -> dict:
    row = np.zeros(10)
    row[2] = 9.81
    row[6:] = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))  # qx qy qz qw
    return SensorMapper().dicts(Readings("imu", Imu, np.array([10**9]), row[None]))[0]


def test_magnetic_field_is_earths_field_seen_from_the_body():
    level = _imu(0.0)
    assert level["magnetic_field"] == pytest.approx(list(EARTH_FIELD_ENU))
    assert np.linalg.norm(level["magnetic_field"]) == pytest.approx(23_000.0)
    east, north, up = EARTH_FIELD_ENU
    facing_north = _imu(math.pi / 2)  # body x points north, body y points west
    assert facing_north["magnetic_field"] == pytest.approx([north, -east, up])
    assert level["timestamp"] == 1.0 and level["linear_acceleration"] == [0.0, 0.0, 9.81]


def test_integrated_odometry_is_relative_to_the_start_pose():
    stamps = np.array([0, 10**8, 2 * 10**8])
    # the car starts at (10, 5) heading north (yaw pi/2) and drives 2 m north, then turns left a little
    rows = np.array([[10.0, 5.0, math.pi / 2, 0.0, 0.0],
                     [10.0, 7.0, math.pi / 2, 3.0, 0.0],
                     [9.0, 8.0, math.pi / 2 + 0.3, 3.0, 0.5]])
    m = SensorMapper()
    d = m.dicts(Readings("odometry", Odometry, stamps, rows))
    assert (d[0]["x"], d[0]["y"], d[0]["yaw"]) == (0.0, 0.0, 0.0)
    assert (d[1]["x"], d[1]["y"], d[1]["yaw"]) == pytest.approx((2.0, 0.0, 0.0), abs=1e-12)
    assert (d[2]["x"], d[2]["y"], d[2]["yaw"]) == pytest.approx((3.0, 1.0, 0.3), abs=1e-12)
    assert (d[2]["vx"], d[2]["vy"], d[2]["wz"]) == pytest.approx((3 * math.cos(0.3), 3 * math.sin(0.3), 0.5))
    assert list(d[2])[-3:] == ["wz", "wy", "wx"]  # MORSE's field order
    again = m.dicts(Readings("odometry", Odometry, stamps[:1], rows[2:]))  # sim time went back: a reset
    assert (again[0]["x"], again[0]["y"]) == (0.0, 0.0)


def test_steer_force_signs_and_units():
    cmd = steer_force_command({"steer": 0.1, "force": -20.0, "brake": 2.0}, 5)
    assert (cmd.longitudinal, cmd.steer, cmd.stamp_ns) == (Longitudinal.FORCE, 0.1, 5)
    assert cmd.drive == 20.0 * STEER_FORCE_UNIT > 0  # negative MORSE force is forward
    assert cmd.brake == 2.0 * STEER_BRAKE_UNIT
    assert steer_force_command({"force": 10.0}, 0).drive < 0  # fields left out default to 0
    for bad in ({"steer": "a"}, {"force": float("nan")}, {"gear": 1}, [1, 2], None):
        with pytest.raises(CommandValueError):
            steer_force_command(bad, 0)


@pytest.mark.parametrize("field", ["force", "brake"])
def test_a_steer_force_too_large_for_a_force_is_refused_as_sent(field):
    """A finite value whose force in newtons would overflow to infinity is refused naming what was sent."""
    with pytest.raises(CommandValueError, match=f"SteerForce field '{field}' -1e\\+308 is out of range"):
        steer_force_command({field: -1e308}, 0)
    top = sys.float_info.max / (STEER_FORCE_UNIT if field == "force" else STEER_BRAKE_UNIT)
    cmd = steer_force_command({field: top}, 0)
    assert math.isfinite(cmd.drive) and math.isfinite(cmd.brake)


def test_motion_vw_follows_the_curvature_and_limits():
    car = vilma()
    cmd = motion_command(2.0, 0.4, 2.0, car, 0)
    assert cmd.steer == pytest.approx(math.atan(car.wheelbase * 0.4 / 2.0))  # curvature w / v
    assert cmd.drive == 0.0 and cmd.longitudinal == Longitudinal.ACCEL  # already at speed
    assert motion_command(0.0, 1.0, 0.0, car, 0).steer == car.max_steer  # standstill: full lock toward w
    assert motion_command(0.0, -1.0, 0.0, car, 0).steer == -car.max_steer
    assert motion_command(50.0, 0.0, 0.0, car, 0).drive == car.actuators.max_accel
    assert motion_command(0.0, 0.0, 20.0, car, 0).drive == -car.actuators.max_decel
    back = motion_command(-1.0, 0.0, 0.0, car, 0)
    assert back.longitudinal == Longitudinal.FORCE and back.drive < 0


def test_original_services_hold_what_bullet_holds():
    car = OriginalCar()
    car.controlpower(1, 0, 100)  # the original GUI's start-up sequence
    car.steer(1, 0.0)
    car.controlpower(1, 800, 10)
    car.steer(1, -0.3)
    cmd = car.command(7)
    assert (cmd.longitudinal, cmd.drive, cmd.velocity_limit, cmd.steer, cmd.brake) == \
        (Longitudinal.POWER, 800, 10, -0.3, 0.0)
    car.steer(0, 0.5)  # Steering 0: the wheels stay where they were
    car.controlpower(0, 0, 100)  # controlPower 0: the engine keeps its force, the speed limit goes
    cmd = car.command(8)
    assert (cmd.steer, cmd.drive, cmd.velocity_limit) == (-0.3, 800, math.inf)
    car.brake(1, 30)
    car.set_autonomous(1)
    cmd = car.command(9)
    assert cmd.brake == 30 and cmd.autonomous
    with pytest.raises(CommandValueError, match="Steering must be 0 or 1"):
        car.steer(2, 0.1)
    with pytest.raises(CommandValueError, match="finite"):
        car.brake(1, float("inf"))


def test_a_scan_is_morses_laser_scanner_one_entry_a_ray():
    angles, ranges = wall_rays()
    d = laser_dict(wall_scan(stamp_ns=1_500_000_000), laser_range=20.0)
    assert list(d) == ["timestamp", "point_list", "range_list"] and d["timestamp"] == 1.5
    assert len(d["point_list"]) == len(d["range_list"]) == len(angles)
    hit = np.isfinite(ranges)
    pts = np.array(d["point_list"])
    # a hit: the point on the wall along its ray, at the float32 range; no hit: [0, 0, 0] and the laser's reach
    assert np.allclose(pts[hit, 0], WALL, atol=1e-5)
    assert np.allclose(pts[hit, 1], WALL * np.tan(angles[hit]), atol=1e-5)
    assert np.array(d["range_list"])[hit].tolist() == ranges[hit].astype(float).tolist()
    assert np.all(pts[~hit] == 0) and set(np.array(d["range_list"])[~hit]) == {20.0}
    assert laser_dict(wall_scan())["range_list"][0] == LASER_RANGE == 30.0


def test_a_malformed_scan_is_refused():
    scan = wall_scan()
    with pytest.raises(ValueError, match="78 points for 79 finite ranges"):
        laser_dict(PointCloud(1, "laser", scan.points[:-12], scan.ranges))
    with pytest.raises(ValueError, match="not whole float32"):
        laser_dict(PointCloud(1, "laser", scan.points, scan.ranges[:-1]))
    with pytest.raises(ValueError, match="a Pose, not a PointCloud"):
        laser_dict(Pose(1, 0, 0, 0, 0, 0, 0))


def test_the_laser_is_a_component_only_with_a_laser_and_comes_last():
    assert components() == COMPONENTS == components(("camera/front",))
    assert components(("camera/front", "laser")) == (*COMPONENTS, *WORLD_COMPONENTS)
    assert WORLD_COMPONENTS[0].name == "laser" and WORLD_COMPONENTS[0].direction == "OUT"
