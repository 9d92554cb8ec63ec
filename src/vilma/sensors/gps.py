"""GPS: antenna position in local ENU and WGS84, with white noise and a drifting bias.

Local ENU coordinates are around a geodetic origin on the WGS84 ellipsoid (:mod:`vilma.core.geodesy`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.checks import check_numbers
from vilma.core.geodesy import EnuFrame, GeodeticOrigin, enu_to_geodetic
from vilma.core.messages import GpsFix
from vilma.sensors.base import Samples
from vilma.sensors.noise import GaussMarkovBias, gauss_markov_step, standard_normals
from vilma.vehicle.state import HEIGHT, YAW, X, Y


@dataclass(frozen=True, slots=True, kw_only=True)
class GpsParams:
    """GPS receiver."""

    rate_hz: float = 10.0
    """Fix rate [Hz]."""
    horizontal_noise: float = 0.5
    """Standard deviation of east and north [m]."""
    vertical_noise: float = 1.0
    """Standard deviation of up [m]."""
    bias_sigma: float = 0.0
    """Stationary standard deviation of a slowly drifting bias on each axis [m] (0: none)."""
    bias_tau: float = 300.0
    """Correlation time of the bias [s]."""
    offset: tuple[float, float, float] = (0.0, 0.0, 1.5)
    """Antenna position in the body frame from the centre of mass (x forward, y left, z up) [m]."""
    origin: GeodeticOrigin = GeodeticOrigin()

    def __post_init__(self) -> None:
        check_numbers(self, "sensor gps", positive=("rate_hz", "bias_tau"),
                      non_negative=("horizontal_noise", "vertical_noise", "bias_sigma"))


@njit(cache=True, error_model="numpy")
def measure_into(rows, z, extra, noise, offset, sigma, bias, phi, step_sigma, ecef0, axes, out):
    """Fixes of the rows ``rows`` of ``z`` with ``noise`` (n, 6: white, then the bias's) into ``out`` (n, 6), the
    3D plant's height from its ``extra`` added (:data:`~vilma.sensors.base.NO_3D`: none)."""
    for k in range(rows.shape[0]):
        i = rows[k]
        c, s = math.cos(z[i, YAW]), math.sin(z[i, YAW])
        b = gauss_markov_step(bias, phi, step_sigma, noise[k, 3:])
        out[k, 3] = z[i, X] + offset[0] * c - offset[1] * s + sigma[0] * noise[k, 0] + b[0]
        out[k, 4] = z[i, Y] + offset[0] * s + offset[1] * c + sigma[1] * noise[k, 1] + b[1]
        out[k, 5] = offset[2] + sigma[2] * noise[k, 2] + b[2]
    geo = enu_to_geodetic(out[:, 3:], ecef0, axes)
    for k in range(rows.shape[0]):  # element by element: a slice copy compiles its shape check's message
        out[k, 0], out[k, 1], out[k, 2] = geo[k, 0], geo[k, 1], geo[k, 2]
    if extra.shape[0]:  # the 3D plant's climb (altitude to well under a millimetre within kilometres)
        for k in range(rows.shape[0]):
            h = extra[rows[k], HEIGHT]
            out[k, 2] += h
            out[k, 5] += h
    return out


class GpsSensor:
    """Antenna fix: latitude, longitude [deg], altitude [m], local x, y, z [m]."""

    name = "gps"
    message = GpsFix

    def __init__(self, params: GpsParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz
        self.bias = GaussMarkovBias(params.bias_sigma, params.bias_tau, 1.0 / params.rate_hz, 3)
        self.frame = EnuFrame(params.origin)
        self._offset = np.array(params.offset, dtype=float)
        self._sigma = np.array([params.horizontal_noise, params.horizontal_noise, params.vertical_noise])

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng
        self.bias.reset(rng)

    def measure(self, s: Samples) -> np.ndarray:
        b = self.bias
        return measure_into(s.rows, s.z, s.extra, standard_normals(self.rng, len(s), 6), self._offset, self._sigma,
                            b.b, b.phi, b.step_sigma, self.frame.ecef0, self.frame.axes, np.empty((len(s), 6)))
