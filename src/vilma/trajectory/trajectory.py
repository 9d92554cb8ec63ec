"""The trajectory type: points in the ENU plane, optional speeds, arc length, heading, curvature, projection."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

CURVATURE_SPAN = 2.0
"""Arc length [m] over which curvature is measured (steady on recorded paths with jitter)."""


def _circle_curvature(ax, ay, bx, by, cx, cy):
    """Signed curvature of the circle through a, b, c (scalars or arrays); 0 when degenerate."""
    cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
    d = np.hypot(bx - ax, by - ay) * np.hypot(cx - bx, cy - by) * np.hypot(cx - ax, cy - ay)
    return np.divide(2.0 * cross, d, out=np.zeros_like(np.asarray(d, dtype=float)), where=d > 1e-12)


@njit(cache=True)
def _nearest(xy, seg, seg_len2, x, y, lo, hi):
    """Nearest segment in ``lo .. hi-1`` to ``(x, y)``: (index, t, squared distance)."""
    best, bi, bt = np.inf, lo, 0.0
    for i in range(lo, hi):
        rx, ry = x - xy[i, 0], y - xy[i, 1]
        t = (rx * seg[i, 0] + ry * seg[i, 1]) / seg_len2[i] if seg_len2[i] > 1e-18 else 0.0
        t = min(max(t, 0.0), 1.0)
        ex, ey = rx - t * seg[i, 0], ry - t * seg[i, 1]
        d = ex * ex + ey * ey
        if d < best:
            best, bi, bt = d, i, t
    return bi, bt, best


@njit(cache=True)
def _project_track(xy, seg, seg_len, s0, heading, pts, window, jump):
    """Project a sequence of points, each searched near the previous one (all segments when it is lost)."""
    n, m = pts.shape[0], seg.shape[0]
    out = np.empty((n, 3))  # s, cross-track, heading
    seg_len2 = seg_len * seg_len
    prev = -1
    for k in range(n):
        x, y = pts[k, 0], pts[k, 1]
        if prev < 0:
            i, t, d = _nearest(xy, seg, seg_len2, x, y, 0, m)
        else:
            i, t, d = _nearest(xy, seg, seg_len2, x, y, max(0, prev - window), min(m, prev + window + 1))
            if d > jump * jump:
                i, t, d = _nearest(xy, seg, seg_len2, x, y, 0, m)
        prev = i
        h = heading[i]
        px, py = xy[i, 0] + t * seg[i, 0], xy[i, 1] + t * seg[i, 1]
        out[k, 0] = s0[i] + t * seg_len[i]
        out[k, 1] = math.cos(h) * (y - py) - math.sin(h) * (x - px)
        out[k, 2] = h
    return out


@dataclass(frozen=True, slots=True)
class Projection:
    """Where a point falls on a trajectory.

    Attributes:
        index: start of the nearest segment (0 .. n-2; 0 for a single point).
        t: position along that segment, 0..1.
        s: arc length of the projected point [m].
        cross_track: signed distance to the path [m], positive left of its direction.
        heading: path heading on that segment [rad].
        x, y: the projected point [m].
        distance_to_end: arc length left to the last point [m].
    """

    index: int
    t: float
    s: float
    cross_track: float
    heading: float
    x: float
    y: float
    distance_to_end: float


class Trajectory:
    """An immutable polyline of ``n >= 1`` points ``xy`` (n, 2) [m] with optional speeds (n,) [m/s]."""

    __slots__ = ("__dict__", "speed", "xy")

    def __init__(self, xy, speed=None) -> None:
        xy = np.array(xy, dtype=np.float64, copy=True).reshape(-1, 2)
        if len(xy) == 0:
            raise ValueError("a trajectory needs at least one point")
        if not np.isfinite(xy).all():
            raise ValueError("trajectory points must be finite numbers")
        xy.flags.writeable = False
        self.xy = xy
        if speed is not None:
            speed = np.array(speed, dtype=np.float64, copy=True).reshape(-1)
            if speed.shape != (len(xy),) or not np.isfinite(speed).all():
                raise ValueError(f"trajectory speeds must be {len(xy)} finite numbers")
            speed.flags.writeable = False
        self.speed = speed

    @classmethod
    def from_points(cls, points, speed=None) -> Trajectory:
        """A trajectory from any sequence of ``(x, y)`` pairs."""
        return cls(np.asarray(points, dtype=np.float64), speed)

    def __len__(self) -> int:
        return len(self.xy)

    def __repr__(self) -> str:
        return f"Trajectory({len(self)} points, {self.length:.1f} m{', with speeds' if self.speed is not None else ''})"

    @cached_property
    def _seg(self) -> np.ndarray:
        return np.diff(self.xy, axis=0)

    @cached_property
    def _seg_len(self) -> np.ndarray:
        return np.hypot(self._seg[:, 0], self._seg[:, 1])

    @cached_property
    def s(self) -> np.ndarray:
        """Arc length at each point [m], shape (n,)."""
        return np.concatenate([[0.0], np.cumsum(self._seg_len)])

    @property
    def length(self) -> float:
        """Total arc length [m]."""
        return float(self.s[-1])

    @cached_property
    def heading(self) -> np.ndarray:
        """Heading of the segment leaving each point [rad], (n,); zero-length segments take their neighbour's."""
        n = len(self)
        if n < 2:
            return np.zeros(n)
        h = np.arctan2(self._seg[:, 1], self._seg[:, 0])
        ok = self._seg_len > 1e-9
        if not ok.any():
            return np.zeros(n)
        idx = np.where(ok, np.arange(len(h)), -1)
        idx = np.maximum.accumulate(idx)  # carry the last good heading forward
        first = int(np.argmax(ok))
        idx[idx < 0] = first
        h = h[idx]
        return np.append(h, h[-1])

    @cached_property
    def curvature(self) -> np.ndarray:
        """Signed curvature at each point [1/m] (left turns positive), as :meth:`curvature_at`, (n,)."""
        half = 0.5 * CURVATURE_SPAN
        s, x, y = self.s, self.xy[:, 0], self.xy[:, 1]
        ax, ay = np.interp(s - half, s, x), np.interp(s - half, s, y)
        cx, cy = np.interp(s + half, s, x), np.interp(s + half, s, y)
        return _circle_curvature(ax, ay, x, y, cx, cy) * ((s - half >= 0) & (s + half <= self.length))

    def _locate(self, s: float) -> tuple[int, float]:
        s = min(max(float(s), 0.0), self.length)
        i = int(np.searchsorted(self.s, s, side="right")) - 1
        i = min(max(i, 0), max(len(self) - 2, 0))
        seg = self._seg_len[i] if len(self) > 1 else 0.0
        return i, (s - self.s[i]) / seg if seg > 1e-12 else 0.0

    def point_at(self, s: float) -> tuple[float, float]:
        """The point at arc length ``s`` [m] (clamped to the ends)."""
        if len(self) == 1:
            return float(self.xy[0, 0]), float(self.xy[0, 1])
        i, t = self._locate(s)
        p = self.xy[i] + t * self._seg[i]
        return float(p[0]), float(p[1])

    def heading_at(self, s: float, span: float = 1.0) -> float:
        """Path heading at arc length ``s`` [rad]: of the chord over ``span`` [m] around it.

        A chord rather than the local segment, so that recorded paths with
        millimetre jitter (a car at rest while recording) have a steady heading.
        """
        if self.length == 0.0:
            return 0.0
        half = min(0.5 * span, 0.5 * self.length)
        a = min(max(s - half, 0.0), self.length - 2 * half)
        (x0, y0), (x1, y1) = self.point_at(a), self.point_at(a + 2 * half)
        return math.atan2(y1 - y0, x1 - x0)

    def curvature_at(self, s: float, span: float = CURVATURE_SPAN) -> float:
        """Curvature at arc length ``s`` [1/m], left positive: the circle through the points ``span``/2 either side.

        Zero at the ends and on paths shorter than ``span``.
        """
        half = 0.5 * span
        if s - half < 0.0 or s + half > self.length:
            return 0.0
        (ax, ay), (bx, by), (cx, cy) = self.point_at(s - half), self.point_at(s), self.point_at(s + half)
        return float(_circle_curvature(ax, ay, bx, by, cx, cy))

    def speed_at(self, s: float) -> float | None:
        """Speed at arc length ``s`` [m/s] interpolated between points, or None without speeds."""
        if self.speed is None:
            return None
        if len(self) == 1:
            return float(self.speed[0])
        i, t = self._locate(s)
        return float((1 - t) * self.speed[i] + t * self.speed[i + 1])

    def project_track(self, points, window: int = 40, jump: float = 2.0) -> np.ndarray:
        """Project a drive ``points`` (n, 2) [m] in order, each searched near the last (compiled).

        Returns (n, 3): arc length [m], signed cross-track error [m] and path heading [rad] of each
        projection, as :meth:`project`. A point farther than ``jump`` [m] from the segments near the
        last projection is searched on the whole path.
        """
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
        if len(self) == 1:
            return np.zeros((len(pts), 3))
        return _project_track(self.xy, np.ascontiguousarray(self._seg), self._seg_len, self.s,
                              self.heading[:-1].copy(), pts, window, jump)

    def project(self, x: float, y: float, hint: int | None = None, window: int | None = None) -> Projection:
        """Project the point ``(x, y)`` onto the nearest segment.

        With ``hint`` (a previous :attr:`Projection.index`) and ``window``, only
        segments ``hint - window .. hint + window`` are searched: O(window).
        Before the start or past the end the projection clamps to the end points.
        """
        n = len(self)
        if n == 1:
            px, py = float(self.xy[0, 0]), float(self.xy[0, 1])
            return Projection(0, 0.0, 0.0, 0.0, 0.0, px, py, 0.0)
        lo, hi = 0, n - 1  # segment indices lo .. hi-1
        if hint is not None and window is not None:
            hi = min(n - 1, max(hint, 0) + window + 1)
            lo = min(max(0, hint - window), hi - 1)
        a, d, L2 = self.xy[lo:hi], self._seg[lo:hi], self._seg_len[lo:hi] ** 2
        rx, ry = x - a[:, 0], y - a[:, 1]
        t = np.clip(np.divide(rx * d[:, 0] + ry * d[:, 1], L2, out=np.zeros_like(L2), where=L2 > 1e-18), 0.0, 1.0)
        ex, ey = rx - t * d[:, 0], ry - t * d[:, 1]
        k = int(np.argmin(ex * ex + ey * ey))
        i, tk = lo + k, float(t[k])
        seg = self._seg[i]
        h = float(self.heading[i])
        px, py = float(self.xy[i, 0] + tk * seg[0]), float(self.xy[i, 1] + tk * seg[1])
        cross = math.cos(h) * (y - py) - math.sin(h) * (x - px)
        s = float(self.s[i] + tk * self._seg_len[i])
        return Projection(i, tk, s, cross, h, px, py, self.length - s)
