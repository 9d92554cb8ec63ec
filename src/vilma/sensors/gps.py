"""GPS: antenna position in local ENU and WGS84, with white noise and a drifting bias.

Local ENU coordinates are around a geodetic origin on the WGS84 ellipsoid.
The origin goes to ECEF with pymap3d; the way back from ECEF uses
Heikkinen's closed form (exact, and vectorised without pymap3d's per-call
iteration, which cost more than the whole rest of the simulator).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymap3d

from vilma.core.messages import GpsFix
from vilma.sensors.base import Samples
from vilma.sensors.noise import GaussMarkovBias, standard_normals
from vilma.vehicle.state import YAW, X, Y


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
        if not -90.0 <= self.latitude <= 90.0 or not -180.0 <= self.longitude <= 180.0:
            raise ValueError(f"geodetic origin ({self.latitude}, {self.longitude}) is not a valid lat/lon in deg")


WGS84_A = 6378137.0
"""Semi-major axis [m]."""
WGS84_F = 1.0 / 298.257223563
"""Flattening [-]."""


class EnuFrame:
    """Local ENU frame at a geodetic origin; converts ENU [m] to WGS84 latitude, longitude [deg], height [m]."""

    def __init__(self, origin: GeodeticOrigin) -> None:
        lat, lon = np.radians(origin.latitude), np.radians(origin.longitude)
        self.ecef0 = np.array(pymap3d.geodetic2ecef(origin.latitude, origin.longitude, origin.altitude))
        sl, cl, sp, cp = np.sin(lon), np.cos(lon), np.sin(lat), np.cos(lat)
        self.axes = np.array([[-sl, cl, 0.0], [-sp * cl, -sp * sl, cp], [cp * cl, cp * sl, sp]])

    def to_geodetic(self, enu: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ENU points (n, 3) [m] -> latitude, longitude [deg] and height [m], each (n,)."""
        x, y, z = (self.ecef0 + enu @ self.axes).T
        a, f = WGS84_A, WGS84_F
        b = a * (1.0 - f)
        e2 = f * (2.0 - f)
        ep2 = (a * a - b * b) / (b * b)
        p = np.hypot(x, y)
        big_f = 54.0 * b * b * z * z
        g = p * p + (1.0 - e2) * z * z - e2 * (a * a - b * b)
        c = e2 * e2 * big_f * p * p / g**3
        s = np.cbrt(1.0 + c + np.sqrt(c * c + 2.0 * c))
        k = s + 1.0 + 1.0 / s
        pp = big_f / (3.0 * k * k * g * g)
        q = np.sqrt(1.0 + 2.0 * e2 * e2 * pp)
        r0 = -(pp * e2 * p) / (1.0 + q) + np.sqrt(
            0.5 * a * a * (1.0 + 1.0 / q) - pp * (1.0 - e2) * z * z / (q * (1.0 + q)) - 0.5 * pp * p * p)
        u = np.hypot(p - e2 * r0, z)
        v = np.sqrt((p - e2 * r0) ** 2 + (1.0 - e2) * z * z)
        z0 = b * b * z / (a * v)
        return (np.degrees(np.arctan2(z + ep2 * z0, p)), np.degrees(np.arctan2(y, x)),
                u * (1.0 - b * b / (a * v)))


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


class GpsSensor:
    """Antenna fix: latitude, longitude [deg], altitude [m], local x, y, z [m]."""

    name = "gps"
    message = GpsFix

    def __init__(self, params: GpsParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz
        self.bias = GaussMarkovBias(params.bias_sigma, params.bias_tau, 1.0 / params.rate_hz, 3)
        self.frame = EnuFrame(params.origin)

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        self.rng = rng
        self.bias.reset(rng)

    def measure(self, s: Samples) -> np.ndarray:
        n, p = len(s), self.params
        ox, oy, oz = p.offset
        c, sn = np.cos(s.z[:, YAW]), np.sin(s.z[:, YAW])
        enu = np.empty((n, 3))
        enu[:, 0] = s.z[:, X] + ox * c - oy * sn
        enu[:, 1] = s.z[:, Y] + ox * sn + oy * c
        enu[:, 2] = oz
        sigma = (p.horizontal_noise, p.horizontal_noise, p.vertical_noise)
        noise = standard_normals(self.rng, n, 6)
        enu += noise[:, :3] * sigma + self.bias.draw(noise[:, 3:])
        lat, lon, alt = self.frame.to_geodetic(enu)
        return np.column_stack([lat, lon, alt, enu])
