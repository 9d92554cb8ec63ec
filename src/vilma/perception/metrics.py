"""Tracking scored against the truth: the CLEAR MOT metrics (Bernardin & Stiefelhagen 2008, "Evaluating multiple
object tracking performance: the CLEAR MOT metrics"), with detection precision and recall and the position and
velocity errors of the matched pairs."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment


@dataclass(frozen=True, slots=True)
class MotFrame:
    """One time step: the true objects' ids (n,), positions (n, 2) [m] and velocities (n, 2) [m/s], and the
    tracks' ids (m,), positions (m, 2) and velocities (m, 2), in one frame (the world's)."""

    truth_ids: np.ndarray
    truth_xy: np.ndarray
    truth_v: np.ndarray
    track_ids: np.ndarray
    track_xy: np.ndarray
    track_v: np.ndarray


@dataclass(frozen=True, slots=True, kw_only=True)
class MotScore:
    """The scores of a sequence (rates and errors NaN when undefined: no object, no track or no match)."""

    mota: float
    """Multiple object tracking accuracy, 1 - (misses + false positives + identity switches) / objects."""
    motp: float
    """Multiple object tracking precision: the mean distance of the matched pairs [m] (0 is perfect)."""
    precision: float
    """Matches / tracks reported."""
    recall: float
    """Matches / true objects."""
    objects: int
    """True objects summed over the frames."""
    matches: int
    misses: int
    false_positives: int
    id_switches: int
    """Times a true object was matched to another track than the one it was last matched to."""
    position_rmse: float
    """Root mean square distance of the matched pairs [m]."""
    velocity_rmse: float
    """Root mean square difference of the matched pairs' velocity vectors [m/s]."""


def clear_mot(frames: Iterable[MotFrame], threshold: float) -> MotScore:
    """The CLEAR MOT scores of ``frames`` in time order; a true object and a track match only within ``threshold``
    [m] (Bernardin & Stiefelhagen 2008, section 2.1: last frame's pairs are kept while still within it, the others
    assigned by least total distance)."""
    if not (math.isfinite(threshold) and threshold > 0):
        raise ValueError(f"CLEAR MOT threshold must be a positive distance [m], got {threshold!r}")
    last: dict[int, int] = {}  # true id -> the track id it was last matched to, in any frame
    pairs: dict[int, int] = {}  # the same for the previous frame only
    objects = tracks = matches = switches = 0
    dist2 = vel2 = dist = 0.0
    for k, f in enumerate(frames):
        if not (len(f.truth_ids) == len(_xy(f.truth_xy)) == len(_xy(f.truth_v))
                and len(f.track_ids) == len(_xy(f.track_xy)) == len(_xy(f.track_v))):
            raise ValueError(f"CLEAR MOT frame {k}: give as many positions and velocities as ids, for the truth and "
                             "for the tracks")
        d = np.linalg.norm(_xy(f.truth_xy)[:, None] - _xy(f.track_xy)[None], axis=-1)
        rows, cols = _match(f, d, pairs, threshold)
        objects, tracks, matches = objects + len(f.truth_ids), tracks + len(f.track_ids), matches + len(rows)
        pairs = {int(f.truth_ids[i]): int(f.track_ids[j]) for i, j in zip(rows, cols, strict=True)}
        switches += sum(truth in last and last[truth] != track for truth, track in pairs.items())
        last |= pairs
        dist += float(d[rows, cols].sum())
        dist2 += float((d[rows, cols] ** 2).sum())
        vel2 += float(((_xy(f.truth_v)[rows] - _xy(f.track_v)[cols]) ** 2).sum())
    misses, false_positives = objects - matches, tracks - matches
    return MotScore(mota=1 - (misses + false_positives + switches) / objects if objects else math.nan,
                    motp=dist / matches if matches else math.nan,
                    precision=matches / tracks if tracks else math.nan,
                    recall=matches / objects if objects else math.nan, objects=objects, matches=matches,
                    misses=misses, false_positives=false_positives, id_switches=switches,
                    position_rmse=math.sqrt(dist2 / matches) if matches else math.nan,
                    velocity_rmse=math.sqrt(vel2 / matches) if matches else math.nan)


def _xy(a) -> np.ndarray:
    """Pairs as an (n, 2) float array (an empty list too)."""
    return np.asarray(a, float).reshape(-1, 2)


def _match(f: MotFrame, d: np.ndarray, pairs: dict[int, int], threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """The matched (truth rows, track rows) of a frame of distances ``d`` (n, m) [m], given the previous frame's
    ``pairs`` (true id -> track id)."""
    column = {t: j for j, t in enumerate(np.asarray(f.track_ids).tolist())}
    kept = [(i, column[pairs[t]]) for i, t in enumerate(np.asarray(f.truth_ids).tolist())
            if pairs.get(t) in column and d[i, column[pairs[t]]] <= threshold]
    free_rows = np.setdiff1d(np.arange(len(f.truth_ids)), [i for i, _ in kept])
    free_cols = np.setdiff1d(np.arange(len(f.track_ids)), [j for _, j in kept])
    sub = d[np.ix_(free_rows, free_cols)]
    r, c = linear_sum_assignment(np.where(sub <= threshold, sub, 1e6 * threshold))
    ok = sub[r, c] <= threshold
    rows = np.concatenate([[i for i, _ in kept], free_rows[r[ok]]]).astype(np.int64)
    cols = np.concatenate([[j for _, j in kept], free_cols[c[ok]]]).astype(np.int64)
    return rows, cols
