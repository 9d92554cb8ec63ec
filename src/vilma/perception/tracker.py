"""Multi-object tracking of laser boxes: a constant-velocity Kalman filter per track, Mahalanobis gating, global
nearest-neighbour association (Hungarian method, :func:`scipy.optimize.linear_sum_assignment`), birth on M hits
of N scans and death after K misses in a row."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import linear_sum_assignment

from vilma.core.geometry import wrap
from vilma.perception.boxes import BOX_LENGTH, BOX_WIDTH, BOX_X, BOX_Y, BOX_YAW

_H = np.eye(2, 4)  # the boxes measure the position of the state x, y, vx, vy
_I2, _I4 = np.eye(2), np.eye(4)


@dataclass(frozen=True, slots=True, kw_only=True)
class TrackerParams:
    """The tracker."""

    acceleration_noise: float = 2.0
    """Standard deviation of the objects' acceleration [m/s^2], white (the process noise of the constant-velocity
    model)."""
    position_noise: float = 0.2
    """Standard deviation of a box centre's x and y [m]."""
    initial_speed: float = 10.0
    """Standard deviation of a new track's vx and vy [m/s]: how fast an object first seen may move."""
    gate: float = 13.8
    """Largest squared Mahalanobis distance of a box from a track it may update (13.8: 99.9 % of the chi-square
    distribution with 2 degrees of freedom)."""
    confirm_hits: int = 3
    """M: a track is confirmed (reported) once it has been hit in M of its first N scans..."""
    confirm_scans: int = 4
    """N: ... and dropped if not by then."""
    max_misses: int = 3
    """K: a track is dropped after K scans in a row without a box."""
    heading_speed: float = 1.0
    """From this speed [m/s] a track's yaw follows its velocity; slower, it keeps the box's orientation nearest
    its last yaw."""

    def __post_init__(self) -> None:
        for name in ("acceleration_noise", "position_noise", "initial_speed", "gate"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"tracker {name} must be a positive number, got {getattr(self, name)!r}")
        if not (math.isfinite(self.heading_speed) and self.heading_speed >= 0):
            raise ValueError(f"tracker heading_speed must be a number >= 0 [m/s], got {self.heading_speed!r}")
        for name in ("confirm_hits", "confirm_scans", "max_misses"):
            if not (isinstance(getattr(self, name), int) and getattr(self, name) >= 1):
                raise ValueError(f"tracker {name} must be a whole number >= 1, got {getattr(self, name)!r}")
        if self.confirm_hits > self.confirm_scans:
            raise ValueError(f"tracker confirm_hits ({self.confirm_hits}) must be at most confirm_scans "
                             f"({self.confirm_scans}): M hits of N scans")


@dataclass(frozen=True, slots=True)
class Track:
    """A confirmed track in the world frame: its id, centre x, y [m], yaw [rad], velocity vx, vy [m/s], length and
    width [m] (the largest seen), covariance of x, y, vx, vy (4, 4) [m, m/s], and age [s] since its first box."""

    id: int
    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    length: float
    width: float
    covariance: np.ndarray
    age: float

    @property
    def speed(self) -> float:
        """Speed [m/s]."""
        return math.hypot(self.vx, self.vy)


@dataclass(slots=True, kw_only=True)
class _Book:
    """A track's bookkeeping: its id, yaw [rad], length and width [m] (the largest seen), the sim time of its first
    box [ns], its scans and hits so far, its misses in a row, and whether it is confirmed."""

    id: int
    yaw: float
    length: float
    width: float
    born_ns: int
    scans: int = 1
    hits: int = 1
    misses: int = 0
    confirmed: bool


class Tracker:
    """Tracks the boxes of consecutive scans (:func:`~vilma.perception.boxes.fit_boxes`); :meth:`update` once a
    scan. The filters' states live in arrays, one row a track, so that a scan's filtering costs a few array
    operations however many; the bookkeeping in a record a track (a scan sees a few: cheaper than arrays)."""

    def __init__(self, params: TrackerParams = TrackerParams()) -> None:
        self.params = params
        self.reset()

    def reset(self) -> None:
        """Forget every track; ids start again from 1."""
        self._next_id, self._stamp_ns = 1, None
        self._x, self._P = np.zeros((0, 4)), np.zeros((0, 4, 4))
        self._books: list[_Book] = []

    def update(self, stamp_ns: int, boxes: np.ndarray) -> list[Track]:
        """The confirmed tracks after the boxes (n, 5) seen at sim time ``stamp_ns`` [ns] (not before the last)."""
        boxes = np.asarray(boxes, float)
        if boxes.size and not (boxes.ndim == 2 and boxes.shape[1] == 5 and np.isfinite(boxes).all()):
            raise ValueError(f"tracker update at {stamp_ns} ns: boxes must be finite rows of x, y, yaw, length, "
                             f"width (n, 5), got shape {boxes.shape}")
        boxes = boxes.reshape(-1, 5)
        if self._stamp_ns is not None and stamp_ns < self._stamp_ns:
            raise ValueError(f"tracker update at {stamp_ns} ns is before the last one at {self._stamp_ns} ns: "
                             "give the scans in time order (or reset)")
        if not (len(boxes) or self._books):  # nothing seen, nothing tracked (most scans of an empty road)
            self._stamp_ns = stamp_ns
            return []
        self._predict(0.0 if self._stamp_ns is None else (stamp_ns - self._stamp_ns) * 1e-9)
        self._stamp_ns = stamp_ns
        S_inv = self._innovation_inverse(self._P) if len(boxes) and self._books else None
        rows, cols, y = self._associate(boxes[:, BOX_X:BOX_Y + 1], S_inv)
        if len(rows):
            self._correct(rows, boxes[cols], y, S_inv if len(rows) == len(self._books) else S_inv[rows])
        self._count(set(rows.tolist()))
        self._prune()
        if len(cols) < len(boxes):
            free = np.ones(len(boxes), bool)
            free[cols] = False
            self._birth(boxes[free], stamp_ns)
        return self.tracks()

    def tracks(self) -> list[Track]:
        """The confirmed tracks now."""
        return [Track(b.id, *x[:2], b.yaw, *x[2:], b.length, b.width, P.copy(), (self._stamp_ns - b.born_ns) * 1e-9)
                for b, x, P in zip(self._books, self._x.tolist(), self._P, strict=True) if b.confirmed]

    def _predict(self, dt: float) -> None:
        """Move the tracks ``dt`` [s] on at constant velocity (discrete white-noise acceleration, Bar-Shalom et
        al. 2001, eq. 6.3.2-4)."""
        if self._books:
            F, Q = _motion(dt, self.params.acceleration_noise)
            self._x = self._x @ F.T
            self._P = F @ self._P @ F.T + Q

    def _innovation_inverse(self, P: np.ndarray) -> np.ndarray:
        """The inverses of the innovation covariances of tracks of covariances ``P`` (n, 4, 4), (n, 2, 2)."""
        return np.linalg.inv(P[:, :2, :2] + self.params.position_noise ** 2 * _I2)

    def _associate(self, z: np.ndarray, S_inv: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pairs (track rows, box rows) of least total squared Mahalanobis distance, each within the gate, of
        the boxes' centres ``z`` (m, 2) and the tracks of innovation covariances' inverses ``S_inv`` (n, 2, 2), and
        the pairs' innovations (pairs, 2) [m]."""
        if not (self._books and len(z)):
            return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 2))
        y = z[None] - self._x[:, None, :2]
        d2 = np.einsum("nmi,nij,nmj->nm", y, S_inv, y)
        gated = d2 <= self.params.gate
        if gated.shape == (1, 1):  # one track, one box: the one pair if gated (scipy's answer, without its cost)
            rows = np.zeros(int(gated[0, 0]), np.int64)
            return rows, rows, y[0, :len(rows)]
        rows, cols = linear_sum_assignment(np.where(gated, d2, 1e3 * self.params.gate))  # outside: never chosen
        keep = gated[rows, cols]                                                          # over a gated pair
        return rows[keep], cols[keep], y[rows[keep], cols[keep]]

    def _correct(self, rows: np.ndarray, boxes: np.ndarray, y: np.ndarray, S_inv: np.ndarray) -> None:
        """The Kalman update of the tracks ``rows`` with their boxes, of innovations ``y`` (rows, 2) [m] and
        innovation covariances' inverses ``S_inv`` (rows, 2, 2), and their yaw and size."""
        every = len(rows) == len(self._books)  # each track has a box (rows ascending): nothing to gather and scatter
        x, P = (self._x, self._P) if every else (self._x[rows], self._P[rows])
        K = P[:, :, :2] @ S_inv
        x, P = x + np.einsum("nij,nj->ni", K, y), (_I4 - K @ _H) @ P
        if every:
            self._x, self._P = x, P
        else:
            self._x[rows], self._P[rows] = x, P
        speed, heading = np.hypot(x[:, 2], x[:, 3]).tolist(), np.arctan2(x[:, 3], x[:, 2]).tolist()
        for r, box, v, h in zip(rows.tolist(), boxes.tolist(), speed, heading, strict=True):
            b = self._books[r]
            b.yaw, length, width = _aligned(box, h if v >= self.params.heading_speed else b.yaw)
            b.length, b.width = max(b.length, length), max(b.width, width)

    def _count(self, hit: set[int]) -> None:
        """Count a scan in each track's bookkeeping, a hit for the tracks ``hit`` (rows), else a miss."""
        for k, b in enumerate(self._books):
            b.scans += 1
            b.hits, b.misses = (b.hits + 1, 0) if k in hit else (b.hits, b.misses + 1)
            b.confirmed = b.confirmed or b.hits >= self.params.confirm_hits

    def _prune(self) -> None:
        """Drop the tracks missed too often and those not confirmed in time."""
        p = self.params
        keep = [k for k, b in enumerate(self._books)
                if b.misses < p.max_misses and (b.confirmed or b.scans < p.confirm_scans)]
        if len(keep) < len(self._books):
            self._x, self._P, self._books = self._x[keep], self._P[keep], [self._books[k] for k in keep]

    def _birth(self, boxes: np.ndarray, stamp_ns: int) -> None:
        """A new tentative track at each box no track took, at rest with the initial speed's uncertainty."""
        n, p = len(boxes), self.params
        P = np.zeros((n, 4, 4))
        P[:, [0, 1], [0, 1]] = p.position_noise ** 2
        P[:, [2, 3], [2, 3]] = p.initial_speed ** 2
        x = np.zeros((n, 4))
        x[:, :2] = boxes[:, [BOX_X, BOX_Y]]
        self._x, self._P = np.concatenate([self._x, x]), np.concatenate([self._P, P])
        self._books += [_Book(id=self._next_id + k, yaw=box[BOX_YAW], length=box[BOX_LENGTH], width=box[BOX_WIDTH],
                              born_ns=stamp_ns, confirmed=p.confirm_hits <= 1) for k, box in enumerate(boxes.tolist())]
        self._next_id += n


@lru_cache(maxsize=16)  # a scan's dt is nearly always the laser's period
def _motion(dt: float, acceleration_noise: float) -> tuple[np.ndarray, np.ndarray]:
    """The constant-velocity model's transition F and process noise Q (4, 4) over ``dt`` [s] for the acceleration
    noise's standard deviation [m/s^2] (read-only: shared by the scans)."""
    F = np.eye(4)
    F[0, 2] = F[1, 3] = dt
    q = acceleration_noise ** 2 * np.array([[dt ** 4 / 4, dt ** 3 / 2], [dt ** 3 / 2, dt ** 2]])
    Q = np.zeros((4, 4))
    Q[np.ix_([0, 2], [0, 2])] = Q[np.ix_([1, 3], [1, 3])] = q
    F.flags.writeable = Q.flags.writeable = False
    return F, Q


def _aligned(box: list[float], ref: float) -> tuple[float, float, float]:
    """The box's yaw turned by the multiple of pi/2 nearest ``ref`` [rad] (a box's orientation is known only up to
    that), and its extents along and across it [m] (:func:`wrap` gives :func:`~vilma.core.geometry.wrap_angle`'s
    values)."""
    quarter = round(wrap(ref - box[BOX_YAW]) / (math.pi / 2))
    length, width = (box[BOX_WIDTH], box[BOX_LENGTH]) if quarter % 2 else (box[BOX_LENGTH], box[BOX_WIDTH])
    return wrap(box[BOX_YAW] + quarter * math.pi / 2), length, width
