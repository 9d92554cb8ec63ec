"""Oriented boxes around laser clusters: search-based L-shape fitting with the closeness criterion (Zhang et al.
2017, "Efficient L-shape fitting for vehicle detection using laser scanners", Algorithms 1 and 4)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import accumulate

import numpy as np
from numba import njit

from vilma.core.geometry import wrap

BOX_X, BOX_Y, BOX_YAW, BOX_LENGTH, BOX_WIDTH = range(5)
"""Columns of a box: centre x, y [m], yaw [rad] of its length, length and width [m] (length >= width)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class BoxParams:
    """The L-shape search."""

    angle_step: float = math.radians(1.0)
    """Step of the searched orientations over [0, pi/2) [rad]."""
    min_distance: float = 0.01
    """d0 of the closeness criterion [m]: nearer points score as this near (Zhang et al. 2017, Algorithm 4)."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.angle_step) and 0 < self.angle_step <= math.pi / 2):
            raise ValueError(f"box angle_step must be in (0, pi/2] rad, got {self.angle_step!r}")
        if not (math.isfinite(self.min_distance) and self.min_distance > 0):
            raise ValueError(f"box min_distance must be a positive number [m], got {self.min_distance!r}")


@njit(cache=True)
def _closeness(xy, c, s, d0):
    """The closeness score of the rectangle edges along (c, s) and (-s, c) to the points ``xy`` (n, 2): each
    point's distance to the nearer of the two edges, each edge the one of its pair the points lie nearer to as a
    whole. In passes over the points rather than with arrays: this runs for every cluster and orientation."""
    n = xy.shape[0]
    lo1 = hi1 = xy[0, 0] * c + xy[0, 1] * s
    lo2 = hi2 = -xy[0, 0] * s + xy[0, 1] * c
    for i in range(1, n):
        c1, c2 = xy[i, 0] * c + xy[i, 1] * s, -xy[i, 0] * s + xy[i, 1] * c
        lo1, hi1, lo2, hi2 = min(lo1, c1), max(hi1, c1), min(lo2, c2), max(hi2, c2)
    to_lo1 = to_hi1 = to_lo2 = to_hi2 = 0.0
    for i in range(n):
        c1, c2 = xy[i, 0] * c + xy[i, 1] * s, -xy[i, 0] * s + xy[i, 1] * c
        to_lo1, to_hi1 = to_lo1 + (c1 - lo1) ** 2, to_hi1 + (hi1 - c1) ** 2
        to_lo2, to_hi2 = to_lo2 + (c2 - lo2) ** 2, to_hi2 + (hi2 - c2) ** 2
    edge1, edge2 = lo1 if to_lo1 <= to_hi1 else hi1, lo2 if to_lo2 <= to_hi2 else hi2
    score = 0.0
    for i in range(n):
        c1, c2 = xy[i, 0] * c + xy[i, 1] * s, -xy[i, 0] * s + xy[i, 1] * c
        score += 1.0 / max(min(abs(c1 - edge1), abs(c2 - edge2)), d0)
    return score


@njit(cache=True)
def _fit(local, starts, pose, step, d0, out):
    """Fit a box into ``out[k]`` to the points ``local[starts[k]:starts[k + 1]]`` (laser frame) of each cluster
    ``k``, in the world frame of the laser at ``pose`` (x, y [m], yaw [rad]), its yaw in (-pi/2, pi/2] (a box turned
    by pi looks the same)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    xy = np.empty_like(local)
    for i in range(local.shape[0]):
        xy[i, 0] = x + c * local[i, 0] - s * local[i, 1]
        xy[i, 1] = y + s * local[i, 0] + c * local[i, 1]
    angles = math.ceil(math.pi / 2 / step)
    for k in range(starts.shape[0] - 1):
        pts = xy[starts[k]:starts[k + 1]]
        best, theta = -1.0, 0.0
        for a in range(angles):
            score = _closeness(pts, math.cos(a * step), math.sin(a * step), d0)
            if score > best:
                best, theta = score, a * step
        c, s = math.cos(theta), math.sin(theta)
        c1 = pts[:, 0] * c + pts[:, 1] * s
        c2 = -pts[:, 0] * s + pts[:, 1] * c
        m1, m2 = (c1.min() + c1.max()) / 2, (c2.min() + c2.max()) / 2
        out[k, 0], out[k, 1] = m1 * c - m2 * s, m1 * s + m2 * c
        e1, e2 = c1.max() - c1.min(), c2.max() - c2.min()
        if e1 >= e2:
            out[k, 2], out[k, 3], out[k, 4] = wrap(2 * theta) / 2, e1, e2
        else:
            out[k, 2], out[k, 3], out[k, 4] = wrap(2 * (theta + math.pi / 2)) / 2, e2, e1


def fit_boxes(points: np.ndarray, clusters: list[np.ndarray], pose: tuple[float, float, float],
              params: BoxParams = BoxParams()) -> np.ndarray:
    """The box of each cluster in the world frame, (clusters, 5) (columns :data:`BOX_X` ...).

    Args:
        points: the scan's points in the laser frame, (rays, 2) [m] (:func:`~vilma.perception.segment.scan_points`).
        clusters: each cluster's rays (:func:`~vilma.perception.segment.segment`), at least one each.
        pose: the laser's x, y [m] and yaw [rad] in the world frame (:func:`laser_pose`).
        params: the search.

    The box is the smallest rectangle at the best orientation around the points: it spans only the faces the laser
    saw (one face seen gives a width of about zero).
    """
    rays = np.concatenate(clusters) if clusters else np.zeros(0, np.int64)
    local = points[rays]
    sizes = [len(k) for k in clusters]
    if not (all(sizes) and np.isfinite(local).all()):
        raise ValueError("each cluster to fit a box to needs one ray or more, all with returns (finite points): "
                         "give the clusters of segment()")
    starts = np.fromiter(accumulate(sizes, initial=0), np.int64, len(sizes) + 1)
    out = np.empty((len(clusters), 5))
    _fit(local, starts, (float(pose[0]), float(pose[1]), float(pose[2])), params.angle_step, params.min_distance, out)
    return out


def laser_pose(car: tuple[float, float, float], mount: tuple[float, float, float]) -> tuple[float, float, float]:
    """The laser's x, y [m] and yaw [rad] in the world frame from the car's (centre of mass) and the mount's x, y
    [m] and yaw [rad] in the body frame."""
    x, y, yaw = car
    c, s = math.cos(yaw), math.sin(yaw)
    return x + c * mount[0] - s * mount[1], y + s * mount[0] + c * mount[1], yaw + mount[2]
