"""Ground-truth pose of the centre of mass (MORSE's ``Pose``), optionally with noise."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vilma.core.geometry import wrap_angle
from vilma.core.messages import Pose
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.vehicle.state import YAW, X, Y


@dataclass(frozen=True, slots=True, kw_only=True)
class PoseParams:
    """Pose sensor."""

    rate_hz: float = 50.0
    """Sample rate [Hz]."""
    position_noise: float = 0.0
    """Standard deviation of x and y [m]."""
    yaw_noise: float = 0.0
    """Standard deviation of yaw [rad]."""


class PoseSensor:
    """Position [m] and ZYX Euler angles [rad]; the planar plant has z = roll = pitch = 0."""

    name = "pose"
    message = Pose

    def __init__(self, params: PoseParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng

    def measure(self, s: Samples) -> np.ndarray:
        n, p = len(s), self.params
        out = np.zeros((n, 6))
        out[:, 0] = s.z[:, X]
        out[:, 1] = s.z[:, Y]
        out[:, 5] = s.z[:, YAW]
        noise = standard_normals(self.rng, n, 3)
        out[:, :2] += noise[:, :2] * p.position_noise
        out[:, 5] = wrap_angle(out[:, 5] + noise[:, 2] * p.yaw_noise)
        return out
