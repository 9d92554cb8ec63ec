"""A planar laser scanner for the flat-ground plants: rays in the ground plane from a mount on the car, cast
against the outlines of the scene's obstacles where they are at each scan (the 3D plant casts its own rays,
:mod:`vilma.plant3d.laser`). The scans are the 3D laser's :class:`~vilma.core.messages.PointCloud`s."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vilma.core.messages import Message, PointCloud
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.sensors.scene import Scene
from vilma.vehicle.state import YAW, X, Y
from vilma.world.states import states_at


@njit(cache=True)
def _hit(ax, ay, bx, by, dx, dy):
    """Distance along the ray from the origin in unit direction (dx, dy) to segment a-b (coordinates relative to
    the origin) [m]; inf if it misses or runs parallel."""
    ex, ey = bx - ax, by - ay
    den = dx * ey - dy * ex
    if den == 0.0:
        return math.inf
    r = (ax * ey - ay * ex) / den
    s = (ax * dy - ay * dx) / den
    return r if r >= 0.0 and 0.0 <= s <= 1.0 else math.inf


@njit(cache=True)
def _scan(rows, z, t, states, present, static, dt, ring, outline, radius, mount, bearings, min_range, max_range,
          noise, out):
    """The ranges [m] of every ray (inf: no hit within ``min_range .. max_range``) at the samples ``rows`` of
    ``z`` at obstacle times ``t`` [s] into ``out`` (n, rays); ``noise`` (n, rays) [m] is added to each hit."""
    m, p = outline.shape[0], outline.shape[1]
    pose, seen = np.empty((m, 4)), np.empty(m, np.bool_)
    dx, dy = np.empty(bearings.shape[0]), np.empty(bearings.shape[0])
    for k in range(rows.shape[0]):
        i = rows[k]
        c, s = math.cos(z[i, YAW]), math.sin(z[i, YAW])
        ox, oy = z[i, X] + mount[0] * c - mount[1] * s, z[i, Y] + mount[0] * s + mount[1] * c
        for r in range(bearings.shape[0]):
            dx[r], dy[r] = math.cos(z[i, YAW] + mount[2] + bearings[r]), math.sin(z[i, YAW] + mount[2] + bearings[r])
            out[k, r] = math.inf
        states_at(states, present, static, dt, t[k], pose, seen, ring)
        reach = max_range + np.abs(noise[k]).max()
        for n in range(m):
            px, py = pose[n, X] - ox, pose[n, Y] - oy
            if not seen[n] or math.hypot(px, py) - radius[n] > reach:  # wholly out of reach, with the noise
                continue
            co, so = math.cos(pose[n, YAW]), math.sin(pose[n, YAW])
            for e in range(p):
                a, b = outline[n, e], outline[n, (e + 1) % p]
                ax, ay = px + co * a[0] - so * a[1], py + so * a[0] + co * a[1]
                bx, by = px + co * b[0] - so * b[1], py + so * b[0] + co * b[1]
                for r in range(bearings.shape[0]):
                    out[k, r] = min(out[k, r], _hit(ax, ay, bx, by, dx[r], dy[r]))
        for r in range(bearings.shape[0]):
            out[k, r] += noise[k, r]
            if out[k, r] < min_range or out[k, r] > max_range:
                out[k, r] = math.inf


class PlanarLaser:
    """A scanning laser range finder on a flat-ground car, publishing on ``laser`` (as the 3D plant's laser).

    Args:
        name: frame name of the scans.
        mount: position x, y [m] in the body frame from the centre of mass and heading [rad] of the scan's centre
            from body x, counter-clockwise.
        bearings: each ray's bearing from the scan's centre, counter-clockwise [rad], (rays,).
        min_range, max_range: the hits reported lie between these [m] (with the noise).
        noise: standard deviation of each range [m], Gaussian.
        rate_hz: scan rate [Hz].
        scene: the obstacles it sees.
    """

    topic = "laser"

    def __init__(self, *, name: str, mount: tuple[float, float, float], bearings: np.ndarray, min_range: float,
                 max_range: float, noise: float = 0.0, rate_hz: float, scene: Scene) -> None:
        self.name, self.rate_hz, self.scene = name, rate_hz, scene
        self._mount, self._bearings = np.array(mount, float), np.asarray(bearings, float)
        self._limits, self._sigma = (min_range, max_range), noise
        self._radius = scene.radius
        self._unit = np.stack([np.cos(self._bearings), np.sin(self._bearings), np.zeros(len(self._bearings))], -1)

    def reset(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def scan(self, s: Samples, stamp_ns: np.ndarray) -> list[Message]:
        sc = self.scene
        ranges = np.empty((len(s), len(self._bearings)))
        noise = self._sigma * standard_normals(self.rng, len(s), len(self._bearings))
        _scan(s.rows, s.z, sc.times(stamp_ns), sc.states, sc.present, sc.static, sc.dt, sc.ring, sc.outline,
              self._radius, self._mount, self._bearings, *self._limits, noise, ranges)
        out = []
        for t, r in zip(stamp_ns.tolist(), ranges, strict=True):
            hit = np.isfinite(r)
            points = (self._unit[hit] * r[hit, None]).astype("<f4")
            out.append(PointCloud(stamp_ns=t, frame_id=self.name, points=points.tobytes(),
                                  ranges=r.astype("<f4").tobytes()))
        return out
