"""A planning cycle and the tracks it planned among as bus messages: :class:`~vilma.core.messages.LocalPlan` and
:class:`~vilma.core.messages.TrackList`."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vilma.core.messages import LocalPlan, PlannedPath, TrackedObject, TrackList
from vilma.perception import Track
from vilma.planning.planner import Plan, Status

DRAWN_CANDIDATES = 60
"""The most candidates a :class:`~vilma.core.messages.LocalPlan` carries, for drawing: the cheapest free ones and
an even sample of the rejected, at least half of them each when there are as many."""


def track_list(stamp_ns: int, source: str, tracks: Sequence[Track]) -> TrackList:
    """The ``perception/objects`` message of ``tracks`` perceived with ``source`` (``laser`` or ``truth``)."""
    return TrackList(stamp_ns, source, [
        TrackedObject(t.id, t.x, t.y, t.yaw, t.vx, t.vy, t.length, t.width,
                      np.asarray(t.covariance, float).ravel().tolist(), t.age) for t in tracks])


def local_plan(stamp_ns: int, plan: Plan, tracks: Sequence[Track], predicted: np.ndarray,
               drawn: int = DRAWN_CANDIDATES, planning_ms: float = math.nan) -> LocalPlan:
    """The ``planning/plan`` message of a cycle: ``plan``, at most ``drawn`` of its candidates
    (:func:`drawn_candidates`), the ``predicted`` boxes (tracks, times, 5) of ``tracks``, and the cycle's time
    ``planning_ms`` [ms]."""
    c = plan.candidates
    return LocalPlan(stamp_ns, plan.mode, plan.reason, float(plan.t[1] - plan.t[0]), plan.x.tolist(),
                     plan.y.tolist(), plan.speed.tolist(),
                     [PlannedPath(-1, int(c.status[i]), c.x[i].tolist(), c.y[i].tolist())
                      for i in drawn_candidates(c.status, c.cost, drawn)],
                     [PlannedPath(t.id, int(Status.FEASIBLE), p[:, 0].tolist(), p[:, 1].tolist())
                      for t, p in zip(tracks, predicted, strict=True)], planning_ms)


def drawn_candidates(status: np.ndarray, cost: np.ndarray, drawn: int) -> np.ndarray:
    """Indices of at most ``drawn`` candidates to draw: the cheapest free ones, then the rejected at even steps
    through them (each kind gets at least half when it has as many, the other kind the rest)."""
    free = np.flatnonzero(status == Status.FEASIBLE)
    free = free[np.argsort(cost[free], kind="stable")]
    rejected = np.flatnonzero(status != Status.FEASIBLE)
    n_free = min(len(free), max(drawn - len(rejected), drawn // 2))
    n_rejected = min(len(rejected), drawn - n_free)
    sample = rejected[np.linspace(0, len(rejected) - 1, n_rejected).round().astype(int)] if n_rejected else rejected[:0]
    return np.concatenate([free[:n_free], np.unique(sample)])
