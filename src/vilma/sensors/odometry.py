"""Wheel odometry: dead reckoning from the rear wheel speeds.

Speed ``v = R (w_RL + w_RR) / 2`` and yaw rate ``R (w_RR - w_RL) / track``
from noisy rear wheel speeds (with a per-run scale error), integrated at the
sensor's rate with the trapezoidal rule and the midpoint heading. It starts at the car's initial pose
and drifts, as odometry does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vilma.core.geometry import wrap_angle
from vilma.core.messages import Odometry
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.sensors.wheel_speed import wheel_speeds
from vilma.vehicle.params import VehicleParams
from vilma.vehicle.state import YAW, X, Y


@dataclass(frozen=True, slots=True, kw_only=True)
class OdometryParams:
    """Wheel odometry."""

    rate_hz: float = 50.0
    """Integration and output rate [Hz]."""
    wheel_noise: float = 0.05
    """Standard deviation of each rear wheel speed it reads [rad/s]."""
    scale_error: float = 0.001
    """Standard deviation of each rear wheel's radius error, drawn once per run [-].

    A mismatch between the two wheels turns straight lines into arcs (yaw
    drift ``v * mismatch / track``): 0.1 % is a calibrated car."""


class OdometrySensor:
    """Dead-reckoned x, y [m], yaw [rad], speed [m/s], yaw rate [rad/s]."""

    name = "odometry"
    message = Odometry

    def __init__(self, params: OdometryParams, vehicle: VehicleParams) -> None:
        self.params, self.vehicle, self.rate_hz = params, vehicle, params.rate_hz
        self.period = 1.0 / params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng
        self.scale = 1.0 + rng.standard_normal(2) * self.params.scale_error
        self.x, self.y, self.yaw = float(z0[X]), float(z0[Y]), float(z0[YAW])
        self.speed, self.rate = self._kinematics(wheel_speeds(z0[None, :], self.vehicle)[:, 2:])

    def _kinematics(self, rear: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        v = self.vehicle
        return v.wheel_radius * 0.5 * (rear[:, 0] + rear[:, 1]), v.wheel_radius * (rear[:, 1] - rear[:, 0]) / v.track

    def measure(self, s: Samples) -> np.ndarray:
        n, t = len(s), self.period
        rear = wheel_speeds(s.z, self.vehicle)[:, 2:] * self.scale
        speed, rate = self._kinematics(rear + standard_normals(self.rng, n, 2) * self.params.wheel_noise)
        ds = 0.5 * (np.concatenate([self.speed, speed[:-1]]) + speed) * t
        dyaw = 0.5 * (np.concatenate([self.rate, rate[:-1]]) + rate) * t
        # accumulate left to right from the carried state, so chunking never changes a bit
        yaw = np.add.accumulate(np.concatenate([[self.yaw], dyaw]))
        mid = yaw[:-1] + 0.5 * dyaw
        x = np.add.accumulate(np.concatenate([[self.x], ds * np.cos(mid)]))
        y = np.add.accumulate(np.concatenate([[self.y], ds * np.sin(mid)]))
        if n:
            self.x, self.y, self.yaw = float(x[-1]), float(y[-1]), float(yaw[-1])
            self.speed, self.rate = speed[-1:], rate[-1:]
        return np.column_stack([x[1:], y[1:], wrap_angle(yaw[1:]), speed, rate])
