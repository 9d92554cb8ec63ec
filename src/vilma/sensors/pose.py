"""Ground-truth pose of the centre of mass (MORSE's ``Pose``), optionally with noise."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.checks import check_numbers
from vilma.core.geometry import wrap
from vilma.core.messages import Pose
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.vehicle.state import HEIGHT, PITCH, ROLL, YAW, X, Y


@dataclass(frozen=True, slots=True, kw_only=True)
class PoseParams:
    """Pose sensor."""

    rate_hz: float = 50.0
    """Sample rate [Hz]."""
    position_noise: float = 0.0
    """Standard deviation of x and y [m]."""
    yaw_noise: float = 0.0
    """Standard deviation of yaw [rad]."""

    def __post_init__(self) -> None:
        check_numbers(self, "sensor pose", positive=("rate_hz",), non_negative=("position_noise", "yaw_noise"))


@njit(cache=True, error_model="numpy")
def measure_into(rows, z, extra, noise, sigma_xy, sigma_yaw, out):
    """x, y and yaw of the rows ``rows`` of ``z`` with ``noise`` (n, 3) into ``out`` (n, 6), with height, roll and
    pitch from the 3D plant's ``extra`` (:data:`~vilma.sensors.base.NO_3D`: zero, as ``out`` holds them)."""
    for k in range(rows.shape[0]):
        i = rows[k]
        out[k, 0] = z[i, X] + sigma_xy * noise[k, 0]
        out[k, 1] = z[i, Y] + sigma_xy * noise[k, 1]
        if extra.shape[0]:
            out[k, 2], out[k, 3], out[k, 4] = extra[i, HEIGHT], extra[i, ROLL], extra[i, PITCH]
        out[k, 5] = wrap(z[i, YAW] + sigma_yaw * noise[k, 2])
    return out


class PoseSensor:
    """Position [m] and ZYX Euler angles [rad]; the planar plant has z = roll = pitch = 0, the 3D plant's z is
    the centre of mass's height above where it rests on flat ground (so 0 on flat ground in both)."""

    name = "pose"
    message = Pose

    def __init__(self, params: PoseParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng

    def measure(self, s: Samples) -> np.ndarray:
        p = self.params
        return measure_into(s.rows, s.z, s.extra, standard_normals(self.rng, len(s), 3), p.position_noise,
                            p.yaw_noise, np.zeros((len(s), 6)))
