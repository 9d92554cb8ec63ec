"""Velocity of the centre of mass (MORSE's ``Velocity``): body and world linear, body angular."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.checks import check_numbers
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

    def __post_init__(self) -> None:
        check_numbers(self, "sensor velocity", positive=("rate_hz",), non_negative=("linear_noise", "angular_noise"))


NORMALS, NORMALS_3D = 3, 5
"""Standard normals a sample: on a planar plant (body vx, vy, yaw rate), on the 3D plant (then roll, pitch rates)."""


@njit(cache=True, error_model="numpy")
def measure_into(rows, z, extra, noise, sigma_v, sigma_w, out):
    """The velocities of the rows ``rows`` of ``z`` with ``noise`` (n, :data:`NORMALS`) into ``out`` (n, 9), zero
    elsewhere; with the 3D plant's ``extra`` (:data:`~vilma.sensors.base.NO_3D`: none) its vertical velocity and roll
    and pitch rates too (``noise`` (n, :data:`NORMALS_3D`))."""
    for k in range(rows.shape[0]):
        i = rows[k]
        vx = z[i, VX] + sigma_v * noise[k, 0]
        vy = z[i, VY] + sigma_v * noise[k, 1]
        c, s = math.cos(z[i, YAW]), math.sin(z[i, YAW])
        out[k, 0], out[k, 1] = vx, vy
        out[k, 3], out[k, 4] = vx * c - vy * s, vx * s + vy * c
        out[k, 8] = z[i, YAW_RATE] + sigma_w * noise[k, 2]
        if extra.shape[0]:  # body vz to first order in the angles
            e = extra[i]
            out[k, 2] = e[VZ] + vx * math.sin(e[PITCH]) - vy * math.sin(e[ROLL])
            out[k, 5] = e[VZ]
            out[k, 6] = e[WX] + sigma_w * noise[k, 3]
            out[k, 7] = e[WY] + sigma_w * noise[k, 4]
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
        normals = standard_normals(self.rng, len(s), NORMALS_3D if len(s.extra) else NORMALS)
        return measure_into(s.rows, s.z, s.extra, normals, p.linear_noise, p.angular_noise, np.zeros((len(s), 9)))
