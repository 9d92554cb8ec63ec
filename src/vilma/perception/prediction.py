"""The tracked objects' futures over a planning horizon: at constant velocity, or at constant velocity in their
lane's frame (along its centreline and across it) where the lane is known."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vilma.core.geometry import wrap_angle
from vilma.perception.tracker import Track
from vilma.trajectory import Trajectory


def predict(tracks: Sequence[Track], times: np.ndarray, lanes: Sequence[Trajectory | None] | None = None
            ) -> np.ndarray:
    """Each track's box at each of ``times`` [s] from now, (tracks, times, 5): x, y [m], yaw [rad], length, width
    [m] (the columns of :func:`~vilma.perception.boxes.fit_boxes`).

    ``lanes[i]`` (a centreline of two points or more, or None) moves track ``i`` at constant velocity in its frame;
    the others keep their velocity and yaw.
    """
    times = np.asarray(times, float).reshape(-1)
    if not (np.isfinite(times).all() and (times >= 0).all()):
        raise ValueError("prediction times must be finite numbers of seconds >= 0 from now")
    lanes = [None] * len(tracks) if lanes is None else list(lanes)
    if len(lanes) != len(tracks):
        raise ValueError(f"prediction needs one lane (or None) a track: got {len(lanes)} for {len(tracks)} tracks")
    out = np.empty((len(tracks), len(times), 5))
    for i, (track, lane) in enumerate(zip(tracks, lanes, strict=True)):
        out[i, :, :3] = _straight(track, times) if lane is None else _along(track, lane, times)
        out[i, :, 3:] = track.length, track.width
    return out


def _straight(track: Track, times: np.ndarray) -> np.ndarray:
    """x, y, yaw at ``times`` at constant velocity, (times, 3)."""
    return np.column_stack([track.x + track.vx * times, track.y + track.vy * times, np.full(len(times), track.yaw)])


def _along(track: Track, lane: Trajectory, times: np.ndarray) -> np.ndarray:
    """x, y, yaw at ``times`` keeping the track's velocity in the frame of ``lane`` where it projects: along the
    centreline (round its bends) and across it (a lane change goes on), facing its motion in that frame; past either
    end straight on along the end's heading."""
    if len(lane) < 2 or lane.length == 0:
        raise ValueError(f"a lane to predict along needs two distinct points or more, got {len(lane)}")
    p = lane.project(track.x, track.y)
    c, s0 = np.cos(p.heading), np.sin(p.heading)
    along, across = track.vx * c + track.vy * s0, -track.vx * s0 + track.vy * c  # [m/s] in the lane's frame
    s = p.s + along * times
    d = p.cross_track + across * times
    h = lane.heading[np.clip(np.searchsorted(lane.s, s, "right") - 1, 0, len(lane) - 2)]
    beyond = np.minimum(s, 0) + np.maximum(s - lane.length, 0)  # [m] before the start (< 0) or past the end
    x = np.interp(s, lane.s, lane.xy[:, 0]) + beyond * np.cos(h) - d * np.sin(h)
    y = np.interp(s, lane.s, lane.xy[:, 1]) + beyond * np.sin(h) + d * np.cos(h)
    return np.column_stack([x, y, wrap_angle(h + np.arctan2(across, along))])
