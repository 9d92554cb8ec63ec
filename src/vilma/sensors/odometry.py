"""Wheel odometry: dead reckoning from the rear wheel speeds.

Speed ``v = R (w_RL + w_RR) / 2`` and yaw rate ``R (w_RR - w_RL) / track``
from noisy rear wheel speeds (with a per-run scale error), integrated at the
sensor's rate with the trapezoidal rule and the midpoint heading. It starts
at the car's initial pose and drifts, as odometry does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.checks import check_numbers
from vilma.core.geometry import wrap
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

    def __post_init__(self) -> None:
        check_numbers(self, "sensor odometry", positive=("rate_hz",), non_negative=("wheel_noise",))


@njit(cache=True, error_model="numpy")
def integrate_into(rear, noise, sigma, scale, radius, track, period, state, out):
    """Dead-reckon over rows of true rear wheel speeds into ``out`` (n, 5); ``state`` = (x, y, yaw, speed, rate),
    updated in place."""
    for i in range(rear.shape[0]):
        wl = rear[i, 0] * scale[0] + sigma * noise[i, 0]
        wr = rear[i, 1] * scale[1] + sigma * noise[i, 1]
        speed, rate = radius * 0.5 * (wl + wr), radius * (wr - wl) / track
        ds = 0.5 * (state[3] + speed) * period
        dyaw = 0.5 * (state[4] + rate) * period
        mid = state[2] + 0.5 * dyaw
        state[0] += ds * math.cos(mid)
        state[1] += ds * math.sin(mid)
        state[2] += dyaw
        state[3], state[4] = speed, rate
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = state[0], state[1], wrap(state[2]), speed, rate
    return out


class OdometrySensor:
    """Dead-reckoned x, y [m], yaw [rad], speed [m/s], yaw rate [rad/s]."""

    name = "odometry"
    message = Odometry

    def __init__(self, params: OdometryParams, vehicle: VehicleParams) -> None:
        self.params, self.vehicle, self.rate_hz = params, vehicle, params.rate_hz
        self.period = 1.0 / params.rate_hz

    def _rear(self, rows: np.ndarray, z: np.ndarray, speeds=wheel_speeds) -> np.ndarray:
        """The rear wheels' speeds [rad/s] at ``rows`` of ``z``, by ``speeds`` (:func:`wheel_speeds` or its Python
        source, the same arithmetic)."""
        v = self.vehicle
        return speeds(rows, z, v.cg_to_front, v.track, v.wheel_radius)[:, 2:]

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng
        self.scale = 1.0 + rng.standard_normal(2) * self.params.scale_error
        v = self.vehicle
        # one row, so wheel_speeds' Python source: loading its compiled code took 2 ms of a run
        rear = self._rear(np.zeros(1, dtype=np.int64), z0[None, :], wheel_speeds.py_func)[0]
        speed, rate = v.wheel_radius * 0.5 * (rear[0] + rear[1]), v.wheel_radius * (rear[1] - rear[0]) / v.track
        self.state = np.array([z0[X], z0[Y], z0[YAW], speed, rate])

    def measure(self, s: Samples) -> np.ndarray:
        v = self.vehicle
        return integrate_into(self._rear(s.rows, s.z), standard_normals(self.rng, len(s), 2), self.params.wheel_noise,
                              self.scale, v.wheel_radius, v.track, self.period, self.state, np.empty((len(s), 5)))
