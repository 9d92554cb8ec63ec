"""Speed profiles: what speed a car can hold along a path, and when it gets where."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from vilma.trajectory.trajectory import Trajectory

CAP_STEP = 0.05
"""Resolution [m/s] of the cruise speeds :func:`arrival_profile` tries."""
SPEED_MARGIN = 0.5
"""Speed [m/s] kept off each end of an arrival's speed interval: the speed controllers' tracking error."""
ENOUGH_SLACK = 1.0
"""Timing slack [s] beyond which :func:`arrival_profile` takes the faster cruise speed rather than more slack."""


def speed_profile(path: Trajectory, speed: float | None, max_lateral_accel: float, max_decel: float) -> Trajectory:
    """The path with speeds limited by curvature and by braking ahead of each limit.

    Each point's speed is the set ``speed`` (or the path's own), at most
    ``sqrt(a_lat / |kappa|)`` [m/s], and low enough to brake at ``max_decel``
    [m/s^2] to every slower point ahead (a backward pass).
    """
    if speed is None and path.speed is None:
        raise ValueError("speed profile: give a speed or a path with speeds")
    base = np.full(len(path), float(speed)) if speed is not None else np.array(path.speed)
    k = np.abs(path.curvature)
    v = np.minimum(base, np.sqrt(max_lateral_accel / np.maximum(k, 1e-12)))
    ds, v = np.diff(path.s).tolist(), v.tolist()  # Python floats: the loop runs on scalars
    for i in range(len(v) - 2, -1, -1):
        v[i] = min(v[i], math.sqrt(v[i + 1] ** 2 + 2.0 * max_decel * ds[i]))
    return Trajectory(path.xy, v)


@dataclass(frozen=True, slots=True)
class Arrival:
    """A window to be in: arc lengths along the path [m], times from its start [s], speeds [m/s] (closed
    intervals), as a CommonRoad goal's position, time and velocity; and the offsets across the path within it."""

    s: tuple[float, float]
    t: tuple[float, float]
    v: tuple[float, float] = (-math.inf, math.inf)
    d: np.ndarray = field(default_factory=lambda: np.zeros((3, 0)), compare=False)
    """The position's extent across the path (3, m): at arcs ``s`` [m] along the window (the first row), the
    offsets [m] (left positive) from ``lo`` to ``hi`` (the next rows) inside it, interpolated between them; no
    column: any offset."""

    def reached(self, s, t, v):
        """Whether arc length ``s`` [m], time ``t`` [s] and speed ``v`` [m/s] are in its intervals (numbers, or arrays
        that broadcast: element by element)."""
        return ((t >= self.t[0]) & (t <= self.t[1]) & (s >= self.s[0]) & (s <= self.s[1]) & (v >= self.v[0])
                & (v <= self.v[1]))

    def across(self, s, d):
        """Whether offset ``d`` [m] at arc length ``s`` [m] is within its extent across the path (numbers, or arrays
        that broadcast); any offset is, without columns."""
        if not self.d.shape[1]:
            return True
        arc, lo, hi = self.d
        return (d >= np.interp(s, arc, lo)) & (d <= np.interp(s, arc, hi))

    def holds(self, s: float, t: float, v: float, d: float) -> bool:
        """Whether a car at arc length ``s`` [m], time ``t`` [s], speed ``v`` [m/s] and offset ``d`` [m] is in it."""
        return bool(self.reached(s, t, v) and self.across(s, d))


def arrival_profile(path: Trajectory, v0: float, accel: float, decel: float,
                    windows: tuple[Arrival, ...]) -> Trajectory | None:
    """The path's speeds (its limits, e.g. from :func:`speed_profile`) capped at the cruise speed that passes
    through one of ``windows`` with the most slack (up to :data:`ENOUGH_SLACK`), or None if no cruise speed does.

    The car starts at ``v0`` [m/s] on the first point, changes speed at most at ``accel`` / ``decel`` [m/s^2]
    towards ``min(limit, cap)`` and brakes to a stop on the last point. Slack is the timing error the arrival
    tolerates both ways: ``min(t_hi - a, b - t_lo)`` for ``[a, b]`` the times the car is in the window's arc and
    speed intervals. Among equal slack the highest cap wins, so a window the limits already meet with enough
    slack changes nothing (and a crawl through a short window, in it for long, does not beat a brisk pass).
    """
    s, limit = path.s, np.asarray(path.speed, float)
    top = max(float(limit.max()), CAP_STEP)
    caps = np.append(np.arange(CAP_STEP, top, CAP_STEP), top)
    v = _ramps(s, limit, v0, accel, decel, caps)
    with np.errstate(divide="ignore"):
        t = np.concatenate([np.zeros((len(caps), 1)), np.cumsum(2 * np.diff(s) / (v[:, :-1] + v[:, 1:]), axis=1)],
                           axis=1)
    slack = np.minimum(np.max([_slack(s, v, t, w) for w in windows], axis=0), ENOUGH_SLACK)
    best = slack.max()
    if not best >= 0:
        return None
    i = np.flatnonzero(slack >= best - 1e-6)[-1]
    return Trajectory(path.xy, v[i])


def _ramps(s: np.ndarray, limit: np.ndarray, v0: float, accel: float, decel: float,
           caps: np.ndarray) -> np.ndarray:
    """Speeds (caps, n) [m/s] at arc lengths ``s`` (n,) [m]: from ``v0`` towards ``min(limit, cap)`` at most at
    ``accel`` up and ``decel`` down (a forward pass), braking at ``decel`` ahead of every slower point and to a
    stop on the last (a backward pass)."""
    target = np.minimum(limit[None, :], caps[:, None])
    up, down = 2 * accel * np.diff(s), 2 * decel * np.diff(s)
    v = np.empty_like(target)
    v[:, 0] = v0
    for i in range(1, len(s)):
        w2 = v[:, i - 1] ** 2
        v[:, i] = np.clip(target[:, i], np.sqrt(np.maximum(w2 - down[i - 1], 0.0)), np.sqrt(w2 + up[i - 1]))
    v[:, -1] = 0.0
    for i in range(len(s) - 2, -1, -1):
        v[:, i] = np.minimum(v[:, i], np.sqrt(v[:, i + 1] ** 2 + down[i]))
    return v


def _slack(s: np.ndarray, v: np.ndarray, t: np.ndarray, w: Arrival) -> np.ndarray:
    """Each profile's slack [s] (caps,) for window ``w`` (-inf: never in it); speeds ``v`` and times ``t`` (caps, n)
    at ``s`` (n,), evaluated at the path's points inside the arc interval and at its two ends, with the speed
    interval narrowed by :data:`SPEED_MARGIN` on each side (by a quarter of its width if narrower)."""
    lo, hi = max(w.s[0], s[0]), min(w.s[1], s[-1])
    if lo > hi:
        return np.full(len(v), -np.inf)
    grid = np.unique(np.concatenate([[lo, hi], s[(s > lo) & (s < hi)]]))
    j = np.clip(np.searchsorted(s, grid, side="right"), 1, len(s) - 1)
    f = (grid - s[j - 1]) / (s[j] - s[j - 1])
    vg, tg = v[:, j - 1] * (1 - f) + v[:, j] * f, t[:, j - 1] * (1 - f) + t[:, j] * f
    margin = min(SPEED_MARGIN, (w.v[1] - w.v[0]) / 4)
    ok = (vg >= w.v[0] + margin) & (vg <= w.v[1] - margin) & np.isfinite(tg)
    return np.array([_slack_of(times, inside, w.t) for times, inside in zip(tg, ok, strict=True)])


def _slack_of(times: np.ndarray, ok: np.ndarray, window: tuple[float, float]) -> float:
    """The largest ``d`` [s] such that the drive shifted by any time in ``[-d, d]`` is still ok at some time in
    ``window``, the drive ok over each run of consecutive ``ok`` samples at ``times`` (increasing) [s]."""
    edges = np.diff(np.concatenate([[0], ok.astype(np.int8), [0]]))
    first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    # the shifts that keep the run [times[a], times[b]] meeting the window: [window lo - times[b], hi - times[a]]
    spans = sorted(zip((window[0] - times[last]).tolist(), (window[1] - times[first]).tolist(), strict=True))
    merged: list[list[float]] = []
    for a, b in spans:
        if merged and a <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], b)
        else:
            merged.append([a, b])
    return next((min(-a, b) for a, b in merged if a <= 0 <= b), -math.inf)
