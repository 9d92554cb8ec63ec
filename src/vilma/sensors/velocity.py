"""Velocity of the centre of mass (MORSE's ``Velocity``): body and world linear, body angular."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vilma.core.messages import Velocity
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.vehicle.state import VX, VY, YAW, YAW_RATE


@dataclass(frozen=True, slots=True, kw_only=True)
class VelocityParams:
    """Velocity sensor."""

    rate_hz: float = 50.0
    """Sample rate [Hz]."""
    linear_noise: float = 0.0
    """Standard deviation of each body linear component [m/s]."""
    angular_noise: float = 0.0
    """Standard deviation of the yaw rate [rad/s]."""


class VelocitySensor:
    """Body (vx, vy, vz), world (vx, vy, vz) [m/s] and body angular (wx, wy, wz) [rad/s]."""

    name = "velocity"
    message = Velocity

    def __init__(self, params: VelocityParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng

    def measure(self, s: Samples) -> np.ndarray:
        n, p = len(s), self.params
        noise = standard_normals(self.rng, n, 3)
        vx = s.z[:, VX] + noise[:, 0] * p.linear_noise
        vy = s.z[:, VY] + noise[:, 1] * p.linear_noise
        c, sn = np.cos(s.z[:, YAW]), np.sin(s.z[:, YAW])
        out = np.zeros((n, 9))
        out[:, 0], out[:, 1] = vx, vy
        out[:, 3], out[:, 4] = vx * c - vy * sn, vx * sn + vy * c
        out[:, 8] = s.z[:, YAW_RATE] + noise[:, 2] * p.angular_noise
        return out
