"""GPS: antenna position in local ENU and WGS84, with white noise and a drifting bias.

Local ENU coordinates are around a geodetic origin on the WGS84 ellipsoid.
The origin goes to ECEF with pymap3d; the way back from ECEF uses
Heikkinen's closed form (exact, compiled, without pymap3d's per-call
iteration, which cost more than the whole rest of the simulator).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d
from numba import njit

from vilma.core.messages import GpsFix
from vilma.sensors.base import Samples
from vilma.sensors.noise import GaussMarkovBias, gauss_markov_step, standard_normals
from vilma.vehicle.state import HEIGHT, YAW, X, Y

WGS84_A = 6378137.0
"""Semi-major axis [m]."""
WGS84_F = 1.0 / 298.257223563
"""Flattening [-]."""


@dataclass(frozen=True, slots=True, kw_only=True)
class GeodeticOrigin:
    """WGS84 point at the local ENU origin. Default: FEM, UNICAMP, Campinas (the VILMA lab)."""

    latitude: float = -22.8195
    """[deg]"""
    longitude: float = -47.0663
    """[deg]"""
    altitude: float = 600.0
    """Height above the ellipsoid [m]."""

    def __post_init__(self) -> None:
        if not (-90.0 <= self.latitude <= 90.0 and -180.0 <= self.longitude <= 180.0):
            raise ValueError(f"geodetic origin ({self.latitude}, {self.longitude}) is not a valid lat/lon in deg")


@njit(cache=True)
def ecef_to_geodetic(x, y, z):
    """ECEF [m] -> latitude, longitude [deg], height [m] on WGS84 (Heikkinen 1982, closed form)."""
    a, f = WGS84_A, WGS84_F
    b = a * (1.0 - f)
    e2 = f * (2.0 - f)
    ep2 = (a * a - b * b) / (b * b)
    p = math.hypot(x, y)
    big_f = 54.0 * b * b * z * z
    g = p * p + (1.0 - e2) * z * z - e2 * (a * a - b * b)
    c = e2 * e2 * big_f * p * p / g**3
    s = (1.0 + c + math.sqrt(c * c + 2.0 * c)) ** (1.0 / 3.0)
    k = s + 1.0 + 1.0 / s
    pp = big_f / (3.0 * k * k * g * g)
    q = math.sqrt(1.0 + 2.0 * e2 * e2 * pp)
    r0 = -(pp * e2 * p) / (1.0 + q) + math.sqrt(
        0.5 * a * a * (1.0 + 1.0 / q) - pp * (1.0 - e2) * z * z / (q * (1.0 + q)) - 0.5 * pp * p * p)
    u = math.hypot(p - e2 * r0, z)
    v = math.sqrt((p - e2 * r0) ** 2 + (1.0 - e2) * z * z)
    z0 = b * b * z / (a * v)
    return math.degrees(math.atan2(z + ep2 * z0, p)), math.degrees(math.atan2(y, x)), u * (1.0 - b * b / (a * v))


class EnuFrame:
    """Local ENU frame at a geodetic origin: ``ecef0`` [m] and the ENU ``axes`` as rows of ECEF vectors."""

    def __init__(self, origin: GeodeticOrigin) -> None:
        lat, lon = math.radians(origin.latitude), math.radians(origin.longitude)
        self.ecef0 = np.array(pymap3d.geodetic2ecef(origin.latitude, origin.longitude, origin.altitude))
        sl, cl, sp, cp = math.sin(lon), math.cos(lon), math.sin(lat), math.cos(lat)
        self.axes = np.array([[-sl, cl, 0.0], [-sp * cl, -sp * sl, cp], [cp * cl, cp * sl, sp]])

    def to_geodetic(self, enu: np.ndarray) -> np.ndarray:
        """ENU points (n, 3) [m] -> (n, 3) latitude, longitude [deg], height [m]."""
        return _enu_to_geodetic(enu, self.ecef0, self.axes)


@njit(cache=True)
def _enu_to_geodetic(enu, ecef0, axes):
    out = np.empty_like(enu)
    for i in range(enu.shape[0]):
        x = ecef0 + enu[i, 0] * axes[0] + enu[i, 1] * axes[1] + enu[i, 2] * axes[2]
        out[i, 0], out[i, 1], out[i, 2] = ecef_to_geodetic(x[0], x[1], x[2])
    return out


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


@njit(cache=True)
def _measure(rows, z, noise, offset, sigma, bias, phi, step_sigma, ecef0, axes):
    out = np.empty((rows.shape[0], 6))
    for k in range(rows.shape[0]):
        i = rows[k]
        c, s = math.cos(z[i, YAW]), math.sin(z[i, YAW])
        b = gauss_markov_step(bias, phi, step_sigma, noise[k, 3:])
        out[k, 3] = z[i, X] + offset[0] * c - offset[1] * s + sigma[0] * noise[k, 0] + b[0]
        out[k, 4] = z[i, Y] + offset[0] * s + offset[1] * c + sigma[1] * noise[k, 1] + b[1]
        out[k, 5] = offset[2] + sigma[2] * noise[k, 2] + b[2]
    out[:, :3] = _enu_to_geodetic(out[:, 3:], ecef0, axes)
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
        out = _measure(s.rows, s.z, standard_normals(self.rng, len(s), 6), self._offset, self._sigma, b.b, b.phi,
                       b.step_sigma, self.frame.ecef0, self.frame.axes)
        if s.extra is not None:  # the 3D plant's climb (altitude to well under a millimetre within kilometres)
            h = s.extra[s.rows, HEIGHT]
            out[:, 2] += h
            out[:, 5] += h
        return out
