"""A road network's lanes for prediction: the lane a moving object is on, and the ways on from there.

Plain arrays, built once from a road network's lanelets (:meth:`~vilma.world.commonroad.RoadNetwork.lanes`): each
lanelet's centre line and its successors. An object is on the lanelet whose centre line passes within half the
lanelet's width of it along its direction of motion (within :data:`LANE_HEADING`); from there each chain of
successors is one way it may go.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

LANE_HEADING = math.radians(45.0)
"""Most angle between an object's motion and the lane it is on [rad]."""
NEAR_SEGMENTS = 8
"""How many segments on from the one an object was on :meth:`Lanes.locate` looks at first."""
MAX_BRANCHES = 4
"""Most ways on a lane leads within the reach asked (the first found, depth first)."""


@dataclass(frozen=True, slots=True, eq=False)
class Lanes:
    """The lanelets' centre lines (each (n_i, 2) [m], in driving direction), their successors (indices) and their
    segments, flat: start and end points (m, 2) [m], lanelet index and start point index (m,), half the lanelet's
    width there (m,) [m]."""

    centres: tuple[np.ndarray, ...]
    successors: tuple[tuple[int, ...], ...]
    a: np.ndarray
    b: np.ndarray
    lane: np.ndarray
    point: np.ndarray
    half_width: np.ndarray

    @classmethod
    def of(cls, centres, widths, successors) -> Lanes:
        """The lanes of lanelets given by their centre lines (n_i, 2) [m], widths at each point (n_i,) [m] and
        successors (indices into the same lists)."""
        centres = tuple(np.asarray(c, float).reshape(-1, 2) for c in centres)
        a = np.concatenate([c[:-1] for c in centres] + [np.zeros((0, 2))])
        b = np.concatenate([c[1:] for c in centres] + [np.zeros((0, 2))])
        lane = np.concatenate([np.full(len(c) - 1, i) for i, c in enumerate(centres)] + [np.zeros(0, int)])
        point = np.concatenate([np.arange(len(c) - 1) for c in centres] + [np.zeros(0, int)])
        half = np.concatenate([0.5 * np.maximum(np.asarray(w[:-1], float), np.asarray(w[1:], float))
                               for w in widths] + [np.zeros(0)])
        return cls(centres, tuple(tuple(int(j) for j in s) for s in successors), a, b, lane.astype(np.int64),
                   point.astype(np.int64), half)

    def locate(self, x: float, y: float, heading: float, near: int | None = None) -> int | None:
        """The segment an object at ``(x, y)`` [m] moving towards ``heading`` [rad] is on: the nearest within half
        its lanelet's width whose direction is within :data:`LANE_HEADING` of the motion; None if none. With
        ``near`` (the segment it was on), the object stays on that lanelet while it is still on one of its segments
        from ``near`` to :data:`NEAR_SEGMENTS` on (projecting within one, not past its ends): a few scalars, not
        the whole network, and no hopping between lanelets that overlap (a fork's)."""
        if near is not None:
            found = self._near(x, y, heading, near)
            if found is not None:
                return found
        ab = self.b - self.a
        length2 = np.maximum((ab**2).sum(axis=1), 1e-12)
        t = np.clip(((x - self.a[:, 0]) * ab[:, 0] + (y - self.a[:, 1]) * ab[:, 1]) / length2, 0.0, 1.0)
        gap = np.hypot(self.a[:, 0] + t * ab[:, 0] - x, self.a[:, 1] + t * ab[:, 1] - y)
        along = (ab[:, 0] * math.cos(heading) + ab[:, 1] * math.sin(heading)) / np.sqrt(length2)
        gap = np.where((gap <= self.half_width) & (along >= math.cos(LANE_HEADING)), gap, np.inf)
        k = int(np.argmin(gap)) if len(gap) else 0
        return k if len(gap) and math.isfinite(gap[k]) else None

    def _near(self, x: float, y: float, heading: float, near: int) -> int | None:
        """:meth:`locate` among the segments of ``near``'s lanelet from ``near`` to :data:`NEAR_SEGMENTS` on, each
        only where the object projects within it."""
        best, gap_best = None, math.inf
        c, s = math.cos(heading), math.sin(heading)
        for k in range(near, min(near + NEAR_SEGMENTS + 1, len(self.lane))):
            if self.lane[k] != self.lane[near]:
                break
            (ax, ay), (bx, by) = self.a[k].tolist(), self.b[k].tolist()
            dx, dy = bx - ax, by - ay
            length = math.hypot(dx, dy)
            if length == 0.0 or (dx * c + dy * s) / length < math.cos(LANE_HEADING):
                continue
            u = ((x - ax) * dx + (y - ay) * dy) / (length * length)
            gap = math.hypot(ax + u * dx - x, ay + u * dy - y)
            if 0.0 <= u <= 1.0 and gap <= self.half_width[k] and gap < gap_best:
                best, gap_best = k, gap
        return best

    def ahead(self, segment: int, reach: float) -> tuple[np.ndarray, ...]:
        """The centre lines from the start of ``segment`` on along each chain of successors until ``reach`` [m]
        past the segment's end (or a lanelet without successors, or one met before on the way): at most
        :data:`MAX_BRANCHES`, (n, 2) [m]."""
        lane, first = int(self.lane[segment]), self.centres[int(self.lane[segment])][int(self.point[segment]):]
        out: list[np.ndarray] = []
        stack = [([first], _length(first[1:]), (lane,))]
        while stack and len(out) < MAX_BRANCHES:
            pieces, length, seen = stack.pop()
            nexts = [j for j in self.successors[seen[-1]] if j not in seen]
            if length >= reach or not nexts:
                out.append(np.concatenate(pieces))
                continue
            for j in reversed(nexts):  # the first successor first
                more = self.centres[j][1:] if np.allclose(self.centres[j][0], pieces[-1][-1]) else self.centres[j]
                stack.append(([*pieces, more], length + _length(np.vstack([pieces[-1][-1:], more])), (*seen, j)))
        return tuple(out)


def _length(xy: np.ndarray) -> float:
    """A polyline's length [m]."""
    return float(np.hypot(*np.diff(xy, axis=0).T).sum())
