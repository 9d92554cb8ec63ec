"""Geodesy: WGS84, a geodetic origin, and local ENU coordinates around it.

Both ways are closed forms. To ECEF: the prime vertical's radius of curvature, as pymap3d computes it (whose
import, 5 ms with dateutil's, was an eighth of what ``vilma run`` adds to the numba floor). Back from ECEF:
Heikkinen's (exact, compiled, without pymap3d's per-call iteration, which cost more than the whole rest of the
simulator).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

WGS84_A = 6378137.0
"""Semi-major axis [m]."""
WGS84_F = 1.0 / 298.257223563
"""Flattening [-]."""
WGS84_B = 6356752.31424518
"""Semi-minor axis [m]: a (1 - f) = 6356752.3142451795 rounded to 10 nm, as geodesy tables and pymap3d give it (the
float product is one unit in the last place lower)."""


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


def geodetic_to_ecef(latitude: float, longitude: float, altitude: float) -> tuple[float, float, float]:
    """Latitude, longitude [deg], height above the ellipsoid [m] -> ECEF x, y, z [m] on WGS84.

    numpy's ``radians``, ``cos``, ``sin`` and ``hypot``, as pymap3d calls them, so the point is pymap3d's to the bit:
    ``math.hypot`` rounds correctly where numpy's (the C library's) is a unit in the last place off, once in some 170
    latitudes."""
    lat, lon = np.radians(latitude), np.radians(longitude)
    cos_lat, sin_lat = np.cos(lat), np.sin(lat)
    n = WGS84_A**2 / np.hypot(WGS84_A * cos_lat, WGS84_B * sin_lat)  # prime vertical's radius [m]
    r = (n + altitude) * cos_lat  # distance from the polar axis [m]
    return float(r * np.cos(lon)), float(r * np.sin(lon)), float((n * (WGS84_B / WGS84_A) ** 2 + altitude) * sin_lat)


class EnuFrame:
    """Local ENU frame at a geodetic origin: ``ecef0`` [m] and the ENU ``axes`` as rows of ECEF vectors."""

    def __init__(self, origin: GeodeticOrigin) -> None:
        lat, lon = math.radians(origin.latitude), math.radians(origin.longitude)
        self.ecef0 = np.array(geodetic_to_ecef(origin.latitude, origin.longitude, origin.altitude))
        sl, cl, sp, cp = math.sin(lon), math.cos(lon), math.sin(lat), math.cos(lat)
        self.axes = np.array([[-sl, cl, 0.0], [-sp * cl, -sp * sl, cp], [cp * cl, cp * sl, sp]])

    def to_geodetic(self, enu: np.ndarray) -> np.ndarray:
        """ENU points (n, 3) [m] -> (n, 3) latitude, longitude [deg], height [m]."""
        return enu_to_geodetic(enu, self.ecef0, self.axes)


@njit(cache=True)
def enu_to_geodetic(enu, ecef0, axes):
    """ENU points (n, 3) [m] around ``ecef0`` (ENU ``axes`` as rows) -> latitude, longitude [deg], height [m]."""
    out = np.empty_like(enu)
    for i in range(enu.shape[0]):
        e, n, u = enu[i, 0], enu[i, 1], enu[i, 2]
        out[i, 0], out[i, 1], out[i, 2] = ecef_to_geodetic(  # on scalars: compiles in a third of the time
            ecef0[0] + e * axes[0, 0] + n * axes[1, 0] + u * axes[2, 0],
            ecef0[1] + e * axes[0, 1] + n * axes[1, 1] + u * axes[2, 1],
            ecef0[2] + e * axes[0, 2] + n * axes[1, 2] + u * axes[2, 2])
    return out
