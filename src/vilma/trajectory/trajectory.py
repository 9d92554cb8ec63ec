"""The trajectory type: points in the ENU plane, optional speeds, arc length, heading, curvature, projection."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
from numba import njit

CURVATURE_SPAN = 2.0
"""Arc length [m] over which curvature is measured (steady on recorded paths with jitter)."""


@njit(cache=True)
def _to_segment(xy, seg, seg_len, i, x, y):
    """Where ``(x, y)`` projects on segment ``i``: (t, squared distance)."""
    rx, ry = x - xy[i, 0], y - xy[i, 1]
    len2 = seg_len[i] * seg_len[i]
    t = (rx * seg[i, 0] + ry * seg[i, 1]) / len2 if len2 > 1e-18 else 0.0
    t = min(max(t, 0.0), 1.0)
    ex, ey = rx - t * seg[i, 0], ry - t * seg[i, 1]
    return t, ex * ex + ey * ey


@njit(cache=True)
def _nearest(xy, seg, seg_len, x, y, lo, hi):
    """Nearest segment in ``lo .. hi-1`` to ``(x, y)``: (index, t, squared distance); the first of equals."""
    best, bi, bt = np.inf, lo, 0.0
    if hi <= lo:
        return bi, bt, best
    # No point of a segment is nearer than its start less its length: segments whose start is farther than
    # that from the nearest distance known (the middle one's, then the best's) are skipped, with a margin far
    # above rounding so that the answer is the full search's.
    reach = math.sqrt(_to_segment(xy, seg, seg_len, (lo + hi) // 2, x, y)[1])
    for i in range(lo, hi):
        rx, ry = x - xy[i, 0], y - xy[i, 1]
        far = (seg_len[i] + reach) * (1.0 + 1e-6) + 1e-6
        if rx * rx + ry * ry > far * far:
            continue
        t, d = _to_segment(xy, seg, seg_len, i, x, y)
        if d < best:
            best, bi, bt, reach = d, i, t, min(reach, math.sqrt(d))
    return bi, bt, best


@njit(cache=True)
def _project_track(xy, seg, seg_len, s0, heading, pts, window, jump):
    """Project a sequence of points, each searched near the previous one (all segments when it is lost)."""
    n, m = pts.shape[0], seg.shape[0]
    out = np.empty((n, 3))  # s, cross-track, heading
    prev, first = -1, np.int64(0)  # an int64, not the literal 0: one compiled _nearest for this and path_project
    for k in range(n):
        x, y = pts[k, 0], pts[k, 1]
        if prev < 0:
            i, t, d = _nearest(xy, seg, seg_len, x, y, first, m)
        else:
            i, t, d = _nearest(xy, seg, seg_len, x, y, max(0, prev - window), min(m, prev + window + 1))
            if d > jump * jump:
                i, t, d = _nearest(xy, seg, seg_len, x, y, first, m)
        prev = i
        h = heading[i]
        px, py = xy[i, 0] + t * seg[i, 0], xy[i, 1] + t * seg[i, 1]
        out[k, 0] = s0[i] + t * seg_len[i]
        out[k, 1] = math.cos(h) * (y - py) - math.sin(h) * (x - px)
        out[k, 2] = h
    return out


_NO_SPEED = np.empty(0)
_NO_SPEED.flags.writeable = False  # read-only as a path's speeds are: compiled code takes both as one type


class PathArrays(NamedTuple):
    """A trajectory as compiled code reads it (see :attr:`Trajectory.arrays`); ``speed`` is empty without speeds."""

    xy: np.ndarray
    seg: np.ndarray
    seg_len: np.ndarray
    s: np.ndarray
    heading: np.ndarray
    speed: np.ndarray


@njit(cache=True)
def path_locate(pa, s):
    """Segment index and fraction (0..1) at arc length ``s`` [m], clamped to the ends."""
    n = pa.xy.shape[0]
    if n < 2:
        return 0, 0.0
    s = min(max(s, 0.0), pa.s[n - 1])
    i = np.searchsorted(pa.s, s, side="right") - 1
    i = min(max(i, 0), n - 2)
    seg = pa.seg_len[i]
    return i, (s - pa.s[i]) / seg if seg > 1e-12 else 0.0


@njit(cache=True)
def path_point_at(pa, s):
    """The point at arc length ``s`` [m]."""
    if pa.xy.shape[0] < 2:
        return pa.xy[0, 0], pa.xy[0, 1]
    i, t = path_locate(pa, s)
    return pa.xy[i, 0] + t * pa.seg[i, 0], pa.xy[i, 1] + t * pa.seg[i, 1]


@njit(cache=True)
def path_heading_at(pa, s, span):
    """Heading [rad] of the chord over ``span`` [m] around arc length ``s``."""
    length = pa.s[-1]
    if length == 0.0:
        return 0.0
    half = min(0.5 * span, 0.5 * length)
    a = min(max(s - half, 0.0), length - 2.0 * half)
    x0, y0 = path_point_at(pa, a)
    x1, y1 = path_point_at(pa, a + 2.0 * half)
    return math.atan2(y1 - y0, x1 - x0)


@njit(cache=True)
def circle_curvature(ax, ay, bx, by, cx, cy):
    """Signed curvature [1/m] of the circle through a, b, c; 0 when degenerate."""
    cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
    d = math.hypot(bx - ax, by - ay) * math.hypot(cx - bx, cy - by) * math.hypot(cx - ax, cy - ay)
    return 2.0 * cross / d if d > 1e-12 else 0.0


@njit(cache=True)
def path_curvature_at(pa, s, span):
    """Curvature [1/m] at arc length ``s``: the circle through the points ``span``/2 either side; 0 near the ends."""
    half = 0.5 * span
    if s - half < 0.0 or s + half > pa.s[-1]:
        return 0.0
    ax, ay = path_point_at(pa, s - half)
    bx, by = path_point_at(pa, s)
    cx, cy = path_point_at(pa, s + half)
    return circle_curvature(ax, ay, bx, by, cx, cy)


@njit(cache=True)
def path_speed_at(pa, s):
    """Speed [m/s] at arc length ``s``, interpolated between points (the path must have speeds)."""
    if pa.xy.shape[0] < 2:
        return pa.speed[0]
    i, t = path_locate(pa, s)
    return (1.0 - t) * pa.speed[i] + t * pa.speed[i + 1]


@njit(cache=True)
def path_project(pa, x, y, hint, window):
    """Project ``(x, y)``: (index, t, s, cross-track, heading, px, py, distance to end).

    With ``hint >= 0``, only segments ``hint - window .. hint + window`` are searched.
    """
    n = pa.xy.shape[0]
    length = pa.s[n - 1]
    if n < 2:
        return 0, 0.0, 0.0, 0.0, 0.0, pa.xy[0, 0], pa.xy[0, 1], 0.0
    lo, hi = 0, n - 1
    if hint >= 0:
        hi = min(n - 1, hint + window + 1)
        lo = min(max(0, hint - window), hi - 1)
    i, t, _ = _nearest(pa.xy, pa.seg, pa.seg_len, x, y, lo, hi)
    h = pa.heading[i]
    px, py = pa.xy[i, 0] + t * pa.seg[i, 0], pa.xy[i, 1] + t * pa.seg[i, 1]
    s = pa.s[i] + t * pa.seg_len[i]
    return i, t, s, math.cos(h) * (y - py) - math.sin(h) * (x - px), h, px, py, length - s


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
        cross = (x - ax) * (cy - y) - (y - ay) * (cx - x)
        d = np.hypot(x - ax, y - ay) * np.hypot(cx - x, cy - y) * np.hypot(cx - ax, cy - ay)
        k = np.divide(2.0 * cross, d, out=np.zeros_like(d), where=d > 1e-12)
        return k * ((s - half >= 0) & (s + half <= self.length))

    @cached_property
    def arrays(self) -> PathArrays:
        """The arrays compiled code reads (:class:`PathArrays`)."""
        speed = self.speed if self.speed is not None else _NO_SPEED
        return PathArrays(self.xy, np.ascontiguousarray(self._seg), self._seg_len, self.s, self.heading, speed)

    def point_at(self, s: float) -> tuple[float, float]:
        """The point at arc length ``s`` [m] (clamped to the ends)."""
        x, y = path_point_at(self.arrays, float(s))
        return float(x), float(y)

    def heading_at(self, s: float, span: float = 1.0) -> float:
        """Path heading at arc length ``s`` [rad]: of the chord over ``span`` [m] around it.

        A chord rather than the local segment, so that recorded paths with
        millimetre jitter (a car at rest while recording) have a steady heading.
        """
        return float(path_heading_at(self.arrays, float(s), float(span)))

    def curvature_at(self, s: float, span: float = CURVATURE_SPAN) -> float:
        """Curvature at arc length ``s`` [1/m], left positive: the circle through the points ``span``/2 either side.

        Zero at the ends and on paths shorter than ``span``.
        """
        return float(path_curvature_at(self.arrays, float(s), float(span)))

    def cut_at(self, point: tuple[float, float]) -> Trajectory:
        """The path (with its speeds) up to where ``point`` [m] projects on it.

        Raises:
            ValueError: the point projects at the path's start.
        """
        p = self.project(*point)
        if p.s <= 0:
            raise ValueError(f"the goal {list(point)} lies at the route's start: give a goal along the route")
        before = self.s < p.s
        speed = None if self.speed is None else np.append(self.speed[before], self.speed_at(p.s))
        return Trajectory(np.vstack([self.xy[before], (p.x, p.y)]), speed)

    def speed_at(self, s: float) -> float | None:
        """Speed at arc length ``s`` [m/s] interpolated between points, or None without speeds."""
        return None if self.speed is None else float(path_speed_at(self.arrays, float(s)))

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
        use_hint = hint is not None and window is not None
        i, t, s, cross, h, px, py, left = path_project(self.arrays, float(x), float(y),
                                                       max(hint, 0) if use_hint else -1, window if use_hint else 0)
        return Projection(int(i), float(t), float(s), float(cross), float(h), float(px), float(py), float(left))
