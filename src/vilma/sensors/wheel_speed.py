"""Wheel angular speeds from the motion of each wheel centre (no longitudinal slip).

A wheel at ``(a, b)`` from the centre of mass (a forward, b left) moves at
``(vx - w b, vy + w a)``; its speed along its own heading (steered by the
front-wheel angle ``d`` at the front) divided by the rolling radius is its
angular speed [rad/s]. Both front wheels turn by the one front-wheel angle
(no Ackermann geometry); a locked or spinning wheel is not modelled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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


def wheel_speeds(z: np.ndarray, v: VehicleParams) -> np.ndarray:
    """True angular speeds [rad/s] of (FL, FR, RL, RR) for plant vectors ``z`` (n, NZ), shape (n, 4)."""
    vx, vy, w, d = z[:, VX], z[:, VY], z[:, YAW_RATE], z[:, STEER]
    half = 0.5 * v.track
    c, s = np.cos(d), np.sin(d)
    front_lat = vy + w * v.cg_to_front
    left, right = vx - w * half, vx + w * half
    return np.column_stack([left * c + front_lat * s, right * c + front_lat * s, left, right]) / v.wheel_radius


class WheelSpeedSensor:
    """Angular speeds of FL, FR, RL, RR [rad/s], positive rolling forward."""

    name = "wheel_speed"
    message = WheelSpeeds

    def __init__(self, params: WheelSpeedParams, vehicle: VehicleParams) -> None:
        self.params, self.vehicle, self.rate_hz = params, vehicle, params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng

    def measure(self, s: Samples) -> np.ndarray:
        return wheel_speeds(s.z, self.vehicle) + standard_normals(self.rng, len(s), 4) * self.params.noise
