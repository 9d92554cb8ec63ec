"""Velocity of the centre of mass (MORSE's ``Velocity``): body and world linear, body angular."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.messages import Velocity
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.vehicle.state import PITCH, ROLL, VX, VY, VZ, WX, WY, YAW, YAW_RATE


@dataclass(frozen=True, slots=True, kw_only=True)
class VelocityParams:
    """Velocity sensor."""

    rate_hz: float = 50.0
    """Sample rate [Hz]."""
    linear_noise: float = 0.0
    """Standard deviation of each body linear component [m/s]."""
    angular_noise: float = 0.0
    """Standard deviation of each body angular rate [rad/s] (the planar plant has only the yaw rate)."""


@njit(cache=True, error_model="numpy")
def measure_into(rows, z, noise, sigma_v, sigma_w, out):
    """The planar velocities of the rows ``rows`` of ``z`` with ``noise`` (n, 3) into ``out`` (n, 9), zero elsewhere."""
    for k in range(rows.shape[0]):
        i = rows[k]
        vx = z[i, VX] + sigma_v * noise[k, 0]
        vy = z[i, VY] + sigma_v * noise[k, 1]
        c, s = math.cos(z[i, YAW]), math.sin(z[i, YAW])
        out[k, 0], out[k, 1] = vx, vy
        out[k, 3], out[k, 4] = vx * c - vy * s, vx * s + vy * c
        out[k, 8] = z[i, YAW_RATE] + sigma_w * noise[k, 2]
    return out


class VelocitySensor:
    """Body (vx, vy, vz), world (vx, vy, vz) [m/s] and body angular (wx, wy, wz) [rad/s]."""

    name = "velocity"
    message = Velocity

    def __init__(self, params: VelocityParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng

    def measure(self, s: Samples) -> np.ndarray:
        p = self.params
        out = measure_into(s.rows, s.z, standard_normals(self.rng, len(s), 3), p.linear_noise, p.angular_noise,
                           np.zeros((len(s), 9)))
        if s.extra is not None:  # vertical motion, roll and pitch rates; body vz to first order in the angles
            e = s.extra[s.rows]
            out[:, 5] = e[:, VZ]
            out[:, 2] = e[:, VZ] + out[:, 0] * np.sin(e[:, PITCH]) - out[:, 1] * np.sin(e[:, ROLL])
            out[:, 6:8] = e[:, WX:WY + 1] + p.angular_noise * standard_normals(self.rng, len(s), 2)
        return out
