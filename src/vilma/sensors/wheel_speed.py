"""Wheel angular speeds from the motion of each wheel centre (no longitudinal slip).

A wheel at ``(a, b)`` from the centre of mass (a forward, b left) moves at
``(vx - w b, vy + w a)``; its speed along its own heading (steered by the
front-wheel angle ``d`` at the front) divided by the rolling radius is its
angular speed [rad/s]. Both front wheels turn by the one front-wheel angle
(no Ackermann geometry); a locked or spinning wheel is not modelled.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.checks import check_numbers
from vilma.core.messages import WheelSpeeds
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.vehicle.params import VehicleParams
from vilma.vehicle.state import STEER, VX, VY, YAW_RATE


@dataclass(frozen=True, slots=True, kw_only=True)
class WheelSpeedParams:
    """Wheel speed sensors."""

    rate_hz: float = 50.0
    """Sample rate [Hz]."""
    noise: float = 0.05
    """Standard deviation of each wheel's angular speed [rad/s]."""

    def __post_init__(self) -> None:
        check_numbers(self, "sensor wheel_speed", positive=("rate_hz",), non_negative=("noise",))


@njit(cache=True, error_model="numpy")
def wheel_speeds(rows, z, lf, track, radius):
    """True angular speeds [rad/s] of (FL, FR, RL, RR) at rows ``rows`` of plant vectors ``z``, shape (n, 4).

    ``lf`` centre of mass to front axle, ``track``, ``radius`` rolling radius [m].
    """
    out = np.empty((rows.shape[0], 4))
    for k in range(rows.shape[0]):
        i = rows[k]
        vx, w, d = z[i, VX], z[i, YAW_RATE], z[i, STEER]
        front_lat = z[i, VY] + w * lf
        left, right = vx - 0.5 * w * track, vx + 0.5 * w * track
        c, s = math.cos(d), math.sin(d)
        out[k, 0] = (left * c + front_lat * s) / radius
        out[k, 1] = (right * c + front_lat * s) / radius
        out[k, 2] = left / radius
        out[k, 3] = right / radius
    return out


@njit(cache=True, error_model="numpy")
def measure_into(rows, z, noise, sigma, lf, track, radius, out):
    """The wheel speeds of :func:`wheel_speeds` with ``sigma`` times ``noise`` (n, 4) added, into ``out`` (n, 4)."""
    true = wheel_speeds(rows, z, lf, track, radius)
    for k in range(rows.shape[0]):
        for j in range(4):
            out[k, j] = true[k, j] + noise[k, j] * sigma
    return out


class WheelSpeedSensor:
    """Angular speeds of FL, FR, RL, RR [rad/s], positive rolling forward."""

    name = "wheel_speed"
    message = WheelSpeeds

    def __init__(self, params: WheelSpeedParams, vehicle: VehicleParams) -> None:
        self.params, self.vehicle, self.rate_hz = params, vehicle, params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng

    def measure(self, s: Samples) -> np.ndarray:
        v = self.vehicle
        return measure_into(s.rows, s.z, standard_normals(self.rng, len(s), 4), self.params.noise, v.cg_to_front,
                            v.track, v.wheel_radius, np.empty((len(s), 4)))
