"""Laser scan segmentation: consecutive returns split where the gap between them is wider than a surface seen at
the beam's angle could make (adaptive breakpoint detection, Borges & Aldon 2004, eq. 4)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from itertools import pairwise

import numpy as np
from numba import njit


@dataclass(frozen=True, slots=True, kw_only=True)
class SegmentParams:
    """The breakpoint detector."""

    angle: float = math.radians(10.0)
    """Smallest angle between a surface and a beam that still counts as one surface, lambda [rad] (Borges & Aldon
    use 10 deg): a surface more nearly parallel to the beams is split."""
    range_noise: float = 0.03
    """Standard deviation of each range [m]: the gap allowed grows by three of them."""
    min_points: int = 3
    """Clusters of fewer returns are dropped (spurious returns, rain, a pole's edge)."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.angle) and 0 < self.angle < math.pi / 2):
            raise ValueError(f"segmentation angle must be in (0, pi/2) rad, got {self.angle!r}")
        if not (math.isfinite(self.range_noise) and self.range_noise >= 0):
            raise ValueError(f"segmentation range_noise must be a number >= 0 [m], got {self.range_noise!r}")
        if not (isinstance(self.min_points, int) and self.min_points >= 1):
            raise ValueError(f"segmentation min_points must be a whole number >= 1, got {self.min_points!r}")


def scan_points(ranges: np.ndarray, bearings: np.ndarray) -> np.ndarray:
    """The returns of a planar scan in the laser frame (x forward, y left), (rays, 2) [m]; no return (inf or NaN
    range) gives NaN."""
    bearings = np.asarray(bearings, float)
    cos, sin = _trig(bearings.tobytes())
    r = np.where(np.isfinite(ranges), ranges, np.nan)  # inf * cos(pi / 2) would warn
    points = np.empty((*r.shape, 2))
    np.multiply(r, cos.reshape(bearings.shape), out=points[..., 0])
    np.multiply(r, sin.reshape(bearings.shape), out=points[..., 1])
    return points


def segment(ranges: np.ndarray, bearings: np.ndarray, params: SegmentParams = SegmentParams()) -> list[np.ndarray]:
    """The clusters of a scan: each the indices of its rays, runs of neighbouring rays with returns.

    Args:
        ranges: each ray's range [m], (rays,); inf or NaN: no return.
        bearings: each ray's bearing [rad], (rays,), increasing.
        params: the detector.

    Neighbouring rays n-1, n at bearings dphi apart join one cluster when both returned and their points are at
    most ``r[n-1] sin(dphi) / sin(lambda - dphi) + 3 sigma`` apart (Borges & Aldon 2004, eq. 4); rays ``lambda``
    or more apart never do. A ray without a return splits: it passed between its neighbours' points.
    """
    ranges, bearings = np.asarray(ranges, float), np.asarray(bearings, float)
    if ranges.ndim != 1 or ranges.shape != bearings.shape:
        raise ValueError(f"a scan needs as many ranges as bearings in 1-D arrays, got shapes {ranges.shape} and "
                         f"{bearings.shape}")
    near, sin_dphi, sin_rest = _breakpoints(bearings.tobytes(), params.angle)
    if (ranges < 0).any():
        raise ValueError(f"a scan's ranges must be >= 0 [m] (inf or NaN: no return), got {ranges.min()!r}")
    cos, sin = _trig(bearings.tobytes())
    rays, starts = _clusters(ranges, cos, sin, near, sin_dphi, sin_rest, 3 * params.range_noise, params.min_points)
    return [rays[a:b] for a, b in pairwise(starts.tolist())]


@njit(cache=True)
def _clusters(ranges, cos, sin, near, sin_dphi, sin_rest, slack, min_points):
    """The rays of the clusters of ``min_points`` returns or more, back to back, and where each cluster starts
    among them and where the last ends, (clusters + 1,) (:func:`segment`; ``near``, ``sin_dphi`` and ``sin_rest``
    of :func:`_breakpoints`, ``slack`` the 3 sigma [m]). One pass over the rays: a scan has mostly no returns, and a
    few clusters, too few for a dozen array operations to pay."""
    rays, starts = np.empty(len(ranges), np.int64), np.zeros(len(ranges) + 1, np.int64)
    kept = clusters = 0  # rays in the kept clusters and the growing one, clusters kept
    j = -1  # the pair of rays i - 1, i among the near ones
    for i in range(len(ranges)):
        joined = False  # rays lambda or more apart, or a ray without a return, never join
        if i > 0 and near[i - 1]:
            j += 1
            if np.isfinite(ranges[i - 1]) and np.isfinite(ranges[i]):
                gap = math.hypot(ranges[i] * cos[i] - ranges[i - 1] * cos[i - 1],
                                 ranges[i] * sin[i] - ranges[i - 1] * sin[i - 1])
                joined = gap <= ranges[i - 1] * sin_dphi[j] / sin_rest[j] + slack
        if not np.isfinite(ranges[i]):
            continue
        if not joined:  # a new cluster: the last one stays if big enough
            if kept - starts[clusters] >= min_points:
                clusters += 1
                starts[clusters] = kept
            kept = starts[clusters]
        rays[kept] = i
        kept += 1
    if kept - starts[clusters] >= min_points:
        clusters += 1
        starts[clusters] = kept
    return rays[:starts[clusters]], starts[:clusters + 1]


@lru_cache(maxsize=8)  # a laser's bearings are the same each scan
def _trig(bearings: bytes) -> tuple[np.ndarray, np.ndarray]:
    """The cosines and sines of the bearings (float64 bytes) [rad], read-only."""
    b = np.frombuffer(bearings)
    out = np.cos(b), np.sin(b)
    for x in out:
        x.flags.writeable = False
    return out


@lru_cache(maxsize=8)
def _breakpoints(bearings: bytes, angle: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For the bearings (float64 bytes) [rad] and lambda ``angle`` [rad]: which neighbours are less than lambda
    apart, and for those sin(dphi) and sin(lambda - dphi), read-only.

    Raises:
        ValueError: bearings not finite or not increasing.
    """
    b = np.frombuffer(bearings)
    if not (np.isfinite(b).all() and (np.diff(b) > 0).all()):
        raise ValueError("a scan's bearings must be finite and increasing [rad]: give the rays in scan order")
    dphi = np.diff(b)
    near = dphi < angle
    out = near, np.sin(dphi[near]), np.sin(angle - dphi[near])
    for x in out:
        x.flags.writeable = False
    return out
