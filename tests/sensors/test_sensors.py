"""Each sensor against the physics of the plant it samples."""

import dataclasses
import math
import zlib

import numpy as np
import pymap3d
import pytest

from vilma.core.geometry import quaternion_from_euler, yaw_from_quaternion
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.sensors import Samples, SensorSuite
from vilma.sensors.base import sensor_rng
from vilma.sensors.gps import GpsParams
from vilma.sensors.imu import ImuParams, ImuSensor
from vilma.sensors.odometry import OdometryParams
from vilma.sensors.pose import PoseParams
from vilma.sensors.wheel_speed import WheelSpeedParams
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.params import GRAVITY, vilma
from vilma.vehicle.state import N3, NX, NZ, PITCH, ROLL, YAW, VehicleState

P = vilma()
NONE = SensorSuite.none()


def _run(seconds, initial=VehicleState(), cmd=ActuatorCommand(), **sensors):
    sim = Simulator(SimConfig(sensors=dataclasses.replace(NONE, **sensors), model="kinematic"))
    sim.reset(initial)
    sim.command(cmd)
    return sim, sim.run_for(seconds)


def test_gps_noise_sigma_over_10000_fixes_and_geodesy():
    g = GpsParams(rate_hz=100.0, horizontal_noise=0.5, vertical_noise=1.0, offset=(1.0, 0.5, 1.5))
    _sim, r = _run(100.0, initial=VehicleState(x=10.0, y=-20.0, yaw=math.pi / 2), gps=g)
    gps = r["gps"]
    assert len(gps) == 10_000
    # antenna 1 m ahead and 0.5 m left of the centre of mass, car facing north
    ex = gps.field("x") - (10.0 - 0.5)
    ny = gps.field("y") - (-20.0 + 1.0)
    up = gps.field("z") - 1.5
    for err, sigma in ((ex, 0.5), (ny, 0.5), (up, 1.0)):
        assert abs(err.mean()) < 4 * sigma / 100
        assert err.std() == pytest.approx(sigma, rel=0.05)
    o = g.origin
    lat, lon, alt = pymap3d.enu2geodetic(gps.field("x"), gps.field("y"), gps.field("z"), o.latitude, o.longitude,
                                         o.altitude)
    np.testing.assert_allclose(gps.field("latitude"), lat, atol=1e-10)
    np.testing.assert_allclose(gps.field("longitude"), lon, atol=1e-10)
    np.testing.assert_allclose(gps.field("altitude"), alt, atol=1e-6)


def test_gps_bias_drift_is_slow_and_has_its_sigma():
    g = GpsParams(horizontal_noise=0.0, vertical_noise=0.0, bias_sigma=2.0, bias_tau=30.0, offset=(0, 0, 0))
    sims = [_run(5.0, gps=g)[1]["gps"] for _ in range(1)]
    x = sims[0].field("x")
    assert np.abs(np.diff(x)).max() < 2.0 * math.sqrt(2 * 0.1 / 30.0) * 5  # steps of a slow process
    finals = []
    for seed in range(300):
        sim = Simulator(SimConfig(sensors=dataclasses.replace(NONE, gps=g), seed=seed))
        finals.append(sim.run_for(0.1)["gps"].field("x")[0])
    assert np.std(finals) == pytest.approx(2.0, rel=0.15)


def test_imu_at_rest_reads_plus_g_with_its_noise():
    imu = ImuParams(accel_noise=0.05, gyro_noise=0.005, accel_bias=0.0, gyro_bias=0.0, orientation_noise=0.0)
    _, r = _run(100.0, imu=imu, initial=VehicleState(yaw=0.7))
    m = r["imu"]
    assert len(m) == 10_000
    assert m.field("az").mean() == pytest.approx(GRAVITY, abs=0.005)
    for f, sigma in (("ax", 0.05), ("ay", 0.05), ("az", 0.05), ("wx", 0.005), ("wz", 0.005)):
        assert m.field(f).std() == pytest.approx(sigma, rel=0.05)
    yaw = yaw_from_quaternion(m.field("qx"), m.field("qy"), m.field("qz"), m.field("qw"))
    np.testing.assert_allclose(yaw, 0.7)


def test_imu_in_a_steady_turn_reads_centripetal_acceleration():
    imu = ImuParams(accel_noise=0.0, gyro_noise=0.0, accel_bias=0.0, gyro_bias=0.0, orientation_noise=0.0,
                    offset=(1.0, 0.0, 0.0))
    v, steer = 5.0, 0.2
    sim, r = _run(5.0, imu=imu, initial=VehicleState(vx=v, steer=steer),
                  cmd=ActuatorCommand(steer=steer, longitudinal=Longitudinal.ACCEL))
    m = r["imu"].latest()
    v = sim.state.vx
    w = v * math.tan(steer) / P.wheelbase
    assert m.wz == pytest.approx(w, rel=1e-3)
    # a = w x v + w x (w x r): lateral v w, and -w^2 r_x along x at a point r_x ahead
    assert m.ay == pytest.approx(v * w, rel=1e-3)
    assert m.ax == pytest.approx(-w * w * 1.0 - w * (P.cg_to_rear * w), rel=1e-3)


def test_imu_sees_longitudinal_acceleration():
    imu = ImuParams(accel_noise=0.0, gyro_noise=0.0, accel_bias=0.0, gyro_bias=0.0)
    _, r = _run(3.0, imu=imu, initial=VehicleState(vx=5.0),
                cmd=ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=2.0))
    assert r["imu"].latest().ax == pytest.approx(2.0, rel=0.01)


def test_wheel_speeds_straight_and_in_a_turn():
    ws = WheelSpeedParams(noise=0.0)
    _, r = _run(1.0, wheel_speed=ws, initial=VehicleState(vx=10.0, drive_force=P.resistance(10)),
                cmd=ActuatorCommand(longitudinal=Longitudinal.ACCEL))
    np.testing.assert_allclose(r["wheel_speed"].values[-1], 10.0 / P.wheel_radius, rtol=1e-6)
    steer = 0.3
    _, r = _run(2.0, wheel_speed=ws, initial=VehicleState(vx=2.0, steer=steer),
                cmd=ActuatorCommand(steer=steer, longitudinal=Longitudinal.ACCEL))
    fl, fr, rl, rr = r["wheel_speed"].values[-1]
    radius = P.wheelbase / math.tan(steer)  # rear axle centre
    # each wheel centre moves at a speed proportional to its distance from the turn centre; both front
    # wheels are steered by the one angle (no Ackermann), so they roll at the part along their heading
    inner = radius - P.track / 2
    assert rr / rl == pytest.approx((radius + P.track / 2) / inner, rel=1e-9)
    ideal = math.atan(P.wheelbase / inner)
    assert fl / rl == pytest.approx(math.hypot(inner, P.wheelbase) / inner * math.cos(ideal - steer), rel=1e-9)
    assert fr > fl


def test_wheel_speed_noise_sigma():
    _, r = _run(200.0, wheel_speed=WheelSpeedParams(noise=0.05))
    assert r["wheel_speed"].values.std(axis=0) == pytest.approx([0.05] * 4, rel=0.05)


def test_odometry_without_noise_follows_a_straight_drive():
    odo = OdometryParams(wheel_noise=0.0, scale_error=0.0)
    sim, r = _run(20.0, odometry=odo, initial=VehicleState(x=3.0, y=4.0, yaw=0.5, vx=8.0),
                  cmd=ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=0.5))
    m = r["odometry"].latest()
    s = sim.state
    assert (m.x, m.y, m.yaw) == pytest.approx((s.x, s.y, s.yaw), abs=1e-4)  # trapezoid over the lag transient


def test_odometry_yaw_follows_a_turn_and_drifts_with_noise():
    odo = OdometryParams(wheel_noise=0.0, scale_error=0.0)
    steer = 0.2
    sim, r = _run(10.0, odometry=odo, initial=VehicleState(vx=5.0, steer=steer),
                  cmd=ActuatorCommand(steer=steer, longitudinal=Longitudinal.ACCEL))
    assert r["odometry"].latest().yaw == pytest.approx(sim.state.yaw, abs=1e-6)
    noisy = OdometryParams(wheel_noise=0.1, scale_error=0.01)
    v = 5.0
    sim, r = _run(60.0, odometry=noisy, initial=VehicleState(vx=v, drive_force=P.resistance(v)),
                  cmd=ActuatorCommand(longitudinal="accel"))
    left, right = sim.sensors[0].scale
    # unequal wheel radii turn a straight drive into a circle: yaw rate v (s_R - s_L) / track
    drift = v * (right - left) / P.track * 60.0
    assert abs(drift) > 0.1
    assert r["odometry"].latest().yaw == pytest.approx(drift, abs=0.15)


def test_pose_noise_when_configured():
    _, r = _run(100.0, pose=PoseParams(rate_hz=100.0, position_noise=0.1, yaw_noise=0.01))
    assert r["pose"].field("x").std() == pytest.approx(0.1, rel=0.05)
    assert r["pose"].field("yaw").std() == pytest.approx(0.01, rel=0.05)


def test_velocity_world_frame_rotates_body_velocity():
    _, r = _run(0.5, velocity=SensorSuite().velocity, initial=VehicleState(vx=10.0, yaw=math.pi / 3))
    v = r["velocity"].latest()
    assert (v.vx_world, v.vy_world) == pytest.approx((v.vx * 0.5, v.vx * math.sqrt(3) / 2))


def test_a_sensors_noise_generator_is_seeded_by_the_run_seed_and_its_name_and_is_its_own():
    a, b = sensor_rng(3, "gps"), sensor_rng(3, "gps")
    expected = np.random.default_rng([3, zlib.crc32(b"gps")]).standard_normal(4)  # the seeding's definition
    assert np.array_equal(a.standard_normal(4), expected)
    assert np.array_equal(b.standard_normal(4), expected)  # a's draws did not advance b
    assert not np.array_equal(sensor_rng(4, "gps").standard_normal(4), expected)
    assert not np.array_equal(sensor_rng(3, "imu").standard_normal(4), expected)


@pytest.mark.parametrize(("roll", "pitch"), [(0.0, 0.0), (0.3, 0.0), (0.0, -0.2), (-0.1, 0.25)])
def test_imu_orientation_is_the_quaternion_of_the_bodys_euler_angles(roll, pitch):
    # on the 3D plant's records (roll and pitch in ``extra``): q = q_z(yaw) q_y(pitch) q_x(roll), ZYX
    imu = ImuSensor(ImuParams(orientation_noise=0.0))
    imu.reset(np.zeros(NZ), sensor_rng(0, "imu"))
    z, extra = np.zeros((1, NZ)), np.zeros((1, N3))
    z[0, YAW], extra[0, ROLL], extra[0, PITCH] = 2.0, roll, pitch
    q = imu.measure(Samples(np.array([0]), z, np.zeros((1, NX)), extra))[0, 6:]
    assert np.allclose(q, quaternion_from_euler(roll, pitch, 2.0), rtol=0.0, atol=1e-15)
