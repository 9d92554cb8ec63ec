"""The EKF in the compiled closed loop: the GPS, IMU and wheel speeds measured and fused every driver period.

The simulator measures its sensors once a block, after the compiled loop has run; a driver that steers by
the EKF needs their readings every period. So the loop measures these three itself, with the sensors' own
compiled kernels on copies of their noise state (the normal draws each sensor takes next,
:meth:`~vilma.sim.simulator.Simulator.normals_ahead`, its biases copied): its readings are the very numbers
the simulator measures after the block, and it fuses them with :func:`~vilma.localization.ekf.fuse` on the
estimator's live arrays, as :meth:`Ekf.update <vilma.localization.ekf.Ekf.update>` does in the Python loop.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from vilma.localization.ekf import Ekf, fuse, pose_of
from vilma.sensors.base import NO_3D, rows_of
from vilma.sensors.gps import GpsSensor
from vilma.sensors.gps import measure_into as gps_measure
from vilma.sensors.imu import ImuSensor
from vilma.sensors.imu import measure_into as imu_measure
from vilma.sensors.imu import planar as imu_ideal
from vilma.sensors.wheel_speed import WheelSpeedSensor, wheel_speeds
from vilma.sim import Simulator


class EkfLoop(NamedTuple):
    """What the compiled loop needs for a block: the estimator's arrays and the three sensors' noise state."""

    s: np.ndarray
    P: np.ndarray
    mem: np.ndarray
    imu_last: np.ndarray
    c: tuple
    """The estimator's :func:`~vilma.localization.ekf.fuse` arguments (:meth:`Ekf.kernel_args`)."""
    tick: int
    """The block's first tick: sample ``i`` of a sensor after it takes row ``i`` of its normals."""
    step_ns: int
    periods: np.ndarray
    """Sample periods [ticks] of the IMU, the wheel speeds and the GPS."""
    imu_normals: np.ndarray
    imu_offset: np.ndarray
    imu_noise: np.ndarray
    """``[accel, gyro, orientation]`` white noise [m/s^2, rad/s, rad]."""
    accel_bias: np.ndarray
    gyro_bias: np.ndarray
    imu_bias_step: np.ndarray
    """``[phi, accel step sigma, gyro step sigma]`` of the IMU's Gauss-Markov biases."""
    wheel_normals: np.ndarray
    wheel_geometry: np.ndarray
    """``[lf, track, radius, noise]`` [m, m, m, rad/s]."""
    gps_normals: np.ndarray
    gps_offset: np.ndarray
    gps_sigma: np.ndarray
    gps_bias: np.ndarray
    gps_bias_step: np.ndarray
    """``[phi, step sigma]`` of the GPS bias."""
    ecef0: np.ndarray
    axes: np.ndarray


def _sensors(sim: Simulator) -> tuple[ImuSensor, WheelSpeedSensor, GpsSensor] | None:
    """The simulator's IMU, wheel speed and GPS sensors, None without one of them."""
    by_name = {s.name: s for s in sim.sensors}
    found = tuple(by_name.get(n) for n in ("imu", "wheel_speed", "gps"))
    return None if None in found else found


def ekf_ok(sim: Simulator) -> bool:
    """Whether :func:`block_inputs` can measure what the EKF reads (the IMU, wheel speeds and GPS are there)."""
    return _sensors(sim) is not None


def _normals(sim: Simulator, sensor, period: int, t0: int, ticks: int) -> np.ndarray:
    """The draws ``sensor`` will take for its samples in ticks ``t0 + 1 .. t0 + ticks`` (the simulator takes the
    same ones when it measures the block)."""
    return sim.normals_ahead(sensor, (t0 + ticks) // period - t0 // period)


def block_inputs(sim: Simulator, est: Ekf, t0: int, ticks: int) -> EkfLoop:
    """The inputs of :func:`ekf_period` for a block of ``ticks`` steps from tick ``t0``."""
    imu, wheel, gps = _sensors(sim)
    periods = np.array([sim.clock.period_ticks(s.rate_hz, f"sensor '{s.name}'") for s in (imu, wheel, gps)])
    i, v, g = imu.params, wheel.vehicle, gps.params
    return EkfLoop(
        *est.kernel_args(), t0, sim.clock.step_ns, periods,
        _normals(sim, imu, int(periods[0]), t0, ticks), np.array(i.offset, dtype=float),
        np.array([i.accel_noise, i.gyro_noise, i.orientation_noise]), imu.accel_bias.b.copy(),
        imu.gyro_bias.b.copy(), np.array([imu.accel_bias.phi, imu.accel_bias.step_sigma, imu.gyro_bias.step_sigma]),
        _normals(sim, wheel, int(periods[1]), t0, ticks),
        np.array([v.cg_to_front, v.track, v.wheel_radius, wheel.params.noise]),
        _normals(sim, gps, int(periods[2]), t0, ticks), np.array(g.offset, dtype=float),
        np.array([g.horizontal_noise, g.horizontal_noise, g.vertical_noise]), gps.bias.b.copy(),
        np.array([gps.bias.phi, gps.bias.step_sigma]), gps.frame.ecef0, gps.frame.axes)


@njit(cache=True)
def _samples(e, sensor, ticks, t0, t1):
    """Rows in ``ticks`` of one sensor's samples in ``t0 + 1 .. t1``, their stamps [ns] and first normals row."""
    period = e.periods[sensor]
    first, count = t0 // period, t1 // period - t0 // period
    stamps = (np.arange(first + 1, first + 1 + count) * period) * e.step_ns
    return rows_of(ticks, period, count), stamps, first - e.tick // period


@njit(cache=True)
def ekf_period(e, z, dx, ticks, t0, t1, ds):
    """Measure the IMU, wheel speeds and GPS at their samples in ticks ``t0 + 1 .. t1`` (the plant recorded at
    ``ticks`` in ``z``, ``dx``), fuse them, and give the driver state ``ds`` the estimate once there is one."""
    rows, imu_t, k = _samples(e, 0, ticks, t0, t1)
    noise, b = e.imu_noise, e.imu_bias_step
    imu = imu_measure(imu_ideal(rows, z, dx, e.imu_offset), e.imu_normals[k:k + len(rows)], noise[0], noise[1],
                      noise[2], e.accel_bias, e.gyro_bias, b[0], b[1], b[2], np.empty((len(rows), 10)))
    rows, wheel_t, k = _samples(e, 1, ticks, t0, t1)
    lf, track, radius, sigma = e.wheel_geometry
    wheel = wheel_speeds(rows, z, lf, track, radius) + e.wheel_normals[k:k + len(rows)] * sigma
    rows, gps_t, k = _samples(e, 2, ticks, t0, t1)
    gps = gps_measure(rows, z, NO_3D, e.gps_normals[k:k + len(rows)], e.gps_offset, e.gps_sigma, e.gps_bias,
                      e.gps_bias_step[0], e.gps_bias_step[1], e.ecef0, e.axes, np.empty((len(rows), 6)))
    fuse(e.s, e.P, e.mem, e.imu_last, imu_t, imu, wheel_t, wheel, gps_t, gps, e.c)
    started, x, y, yaw, speed, yaw_rate = pose_of(e.s, e.mem, e.imu_last)
    if started:
        ds.has_pose, ds.x, ds.y, ds.yaw, ds.pose_speed, ds.yaw_rate = True, x, y, yaw, speed, yaw_rate
        ds.measured = speed
