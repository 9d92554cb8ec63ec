"""IMU: specific force (acceleration minus gravity) and angular velocity in the body frame, orientation.

At a mounting point ``r`` from the centre of mass, for planar motion with
yaw rate ``w`` and yaw acceleration ``dw``::

    a_x = dvx/dt - w vy - dw r_y - w^2 r_x
    a_y = dvy/dt + w vx + dw r_x - w^2 r_y
    a_z = +g      (at rest an accelerometer reads +g upward)

On the 3D plant the accelerometer and gyro are MuJoCo's, at the mounting point: they see the
suspension's motion, roll, pitch and slopes. Each channel gets white noise and a Gauss-Markov bias.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.checks import check_numbers
from vilma.core.geometry import wrap
from vilma.core.messages import Imu
from vilma.sensors.base import Samples
from vilma.sensors.noise import GaussMarkovBias, gauss_markov_step, standard_normals
from vilma.vehicle.params import GRAVITY
from vilma.vehicle.state import FX, PITCH, ROLL, VX, VY, WX, YAW, YAW_RATE


@dataclass(frozen=True, slots=True, kw_only=True)
class ImuParams:
    """Inertial measurement unit."""

    rate_hz: float = 100.0
    """Sample rate [Hz]."""
    accel_noise: float = 0.05
    """White noise standard deviation of each accelerometer axis [m/s^2]."""
    gyro_noise: float = 0.005
    """White noise standard deviation of each gyro axis [rad/s]."""
    accel_bias: float = 0.02
    """Bias standard deviation of each accelerometer axis [m/s^2]."""
    gyro_bias: float = 0.0005
    """Bias standard deviation of each gyro axis [rad/s]."""
    bias_tau: float = 600.0
    """Correlation time of the biases [s]."""
    orientation_noise: float = 0.005
    """Standard deviation of the reported yaw [rad]."""
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Mounting point in the body frame from the centre of mass [m]."""

    def __post_init__(self) -> None:
        check_numbers(self, "sensor imu", positive=("rate_hz", "bias_tau"),
                      non_negative=("accel_noise", "gyro_noise", "accel_bias", "gyro_bias", "orientation_noise"))


@njit(cache=True, error_model="numpy")
def planar(rows, z, dx, offset):
    """Ideal ``fx, fy, fz, wx, wy, wz, roll, pitch, yaw`` of the planar plant (module docstring)."""
    out = np.zeros((rows.shape[0], 9))
    rx, ry = offset[0], offset[1]
    for k in range(rows.shape[0]):
        i = rows[k]
        w, dw = z[i, YAW_RATE], dx[i, YAW_RATE]
        out[k, 0] = dx[i, VX] - w * z[i, VY] - dw * ry - w * w * rx
        out[k, 1] = dx[i, VY] + w * z[i, VX] + dw * rx - w * w * ry
        out[k, 2] = GRAVITY
        out[k, 5] = w
        out[k, 8] = z[i, YAW]
    return out


@njit(cache=True, error_model="numpy")
def ideal(rows, z, dx, extra, offset):
    """Ideal ``fx, fy, fz, wx, wy, wz, roll, pitch, yaw`` of the rows ``rows`` of ``z``: :func:`planar`'s, or with
    the 3D plant's ``extra`` (not :data:`~vilma.sensors.base.NO_3D`) its accelerometer and gyro (at the offset
    already), roll and pitch."""
    if not extra.shape[0]:
        return planar(rows, z, dx, offset)
    out = np.empty((rows.shape[0], 9))
    for k in range(rows.shape[0]):
        i = rows[k]
        for j in range(3):
            out[k, j], out[k, 3 + j] = extra[i, FX + j], extra[i, WX + j]
        out[k, 6], out[k, 7], out[k, 8] = extra[i, ROLL], extra[i, PITCH], z[i, YAW]
    return out


@njit(cache=True, error_model="numpy")
def measure_into(ideal, noise, sigma_a, sigma_w, sigma_yaw, bias_a, bias_w, phi, step_a, step_w, out):
    """Readings of the ``ideal`` values (n, 9) with ``noise`` (n, 13) into ``out`` (n, 10); advances the biases."""
    for k in range(ideal.shape[0]):
        ba = gauss_markov_step(bias_a, phi, step_a, noise[k, 6:9])
        bw = gauss_markov_step(bias_w, phi, step_w, noise[k, 9:12])
        for j in range(3):
            out[k, j] = ideal[k, j] + sigma_a * noise[k, j] + ba[j]
            out[k, 3 + j] = ideal[k, 3 + j] + sigma_w * noise[k, 3 + j] + bw[j]
        r, p, y = 0.5 * ideal[k, 6], 0.5 * ideal[k, 7], 0.5 * wrap(ideal[k, 8] + sigma_yaw * noise[k, 12])
        cr, sr = (1.0, r) if r == 0.0 else (math.cos(r), math.sin(r))  # exact at 0: the planar plant's roll and pitch
        cp, sp = (1.0, p) if p == 0.0 else (math.cos(p), math.sin(p))
        cy, sy = math.cos(y), math.sin(y)
        out[k, 6] = sr * cp * cy - cr * sp * sy
        out[k, 7] = cr * sp * cy + sr * cp * sy
        out[k, 8] = cr * cp * sy - sr * sp * cy
        out[k, 9] = cr * cp * cy + sr * sp * sy
    return out


class ImuSensor:
    """Specific force (ax, ay, az) [m/s^2], angular velocity (wx, wy, wz) [rad/s], quaternion (x, y, z, w)."""

    name = "imu"
    message = Imu

    def __init__(self, params: ImuParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz
        period = 1.0 / params.rate_hz
        self.accel_bias = GaussMarkovBias(params.accel_bias, params.bias_tau, period, 3)
        self.gyro_bias = GaussMarkovBias(params.gyro_bias, params.bias_tau, period, 3)
        self._offset = np.array(params.offset, dtype=float)

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng
        self.accel_bias.reset(rng)
        self.gyro_bias.reset(rng)

    def measure(self, s: Samples) -> np.ndarray:
        p, a, g = self.params, self.accel_bias, self.gyro_bias
        return measure_into(ideal(s.rows, s.z, s.dx, s.extra, self._offset), standard_normals(self.rng, len(s), 13),
                            p.accel_noise, p.gyro_noise, p.orientation_noise, a.b, g.b, a.phi, a.step_sigma,
                            g.step_sigma, np.empty((len(s), 10)))
