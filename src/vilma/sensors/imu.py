"""IMU: specific force (acceleration minus gravity) and angular velocity in the body frame, orientation.

At a mounting point ``r`` from the centre of mass, for planar motion with
yaw rate ``w`` and yaw acceleration ``dw``::

    a_x = dvx/dt - w vy - dw r_y - w^2 r_x
    a_y = dvy/dt + w vx + dw r_x - w^2 r_y
    a_z = +g      (at rest an accelerometer reads +g upward)

Each channel gets white noise and a Gauss-Markov bias.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vilma.core.geometry import quaternion_from_euler, wrap_angle
from vilma.core.messages import Imu
from vilma.sensors.base import Samples
from vilma.sensors.noise import GaussMarkovBias, standard_normals
from vilma.vehicle.params import GRAVITY
from vilma.vehicle.state import VX, VY, YAW, YAW_RATE


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


class ImuSensor:
    """Specific force (ax, ay, az) [m/s^2], angular velocity (wx, wy, wz) [rad/s], quaternion (x, y, z, w)."""

    name = "imu"
    message = Imu

    def __init__(self, params: ImuParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz
        period = 1.0 / params.rate_hz
        self.accel_bias = GaussMarkovBias(params.accel_bias, params.bias_tau, period, 3)
        self.gyro_bias = GaussMarkovBias(params.gyro_bias, params.bias_tau, period, 3)

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng
        self.accel_bias.reset(rng)
        self.gyro_bias.reset(rng)

    def measure(self, s: Samples) -> np.ndarray:
        n, p = len(s), self.params
        rx, ry, _ = p.offset
        w, dw = s.z[:, YAW_RATE], s.dx[:, YAW_RATE]
        out = np.zeros((n, 10))
        out[:, 0] = s.dx[:, VX] - w * s.z[:, VY] - dw * ry - w * w * rx
        out[:, 1] = s.dx[:, VY] + w * s.z[:, VX] + dw * rx - w * w * ry
        out[:, 2] = GRAVITY
        out[:, 5] = w
        noise = standard_normals(self.rng, n, 13)
        out[:, :3] += noise[:, 0:3] * p.accel_noise + self.accel_bias.draw(noise[:, 6:9])
        out[:, 3:6] += noise[:, 3:6] * p.gyro_noise + self.gyro_bias.draw(noise[:, 9:12])
        yaw = wrap_angle(s.z[:, YAW] + noise[:, 12] * p.orientation_noise)
        out[:, 6:10] = np.column_stack(quaternion_from_euler(0.0, 0.0, yaw))
        return out
