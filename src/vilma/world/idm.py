"""The Intelligent Driver Model's period step compiled, on plain arrays (without the roads extra: the compiled
closed loop calls it, as :class:`~vilma.world.reactive.ReactiveTraffic` does from Python).

M. Treiber, A. Hennecke, D. Helbing, "Congested traffic states in empirical observations and microscopic
simulations", Phys. Rev. E 62, 1805 (2000): ``a = a_max [1 - (v/v0)^delta - (s*/s)^2]`` with the desired gap
``s* = s0 + max(0, v T + v dv / (2 sqrt(a_max b)))``, ``s`` the bumper-to-bumper gap and ``dv`` the closing speed.
Integrated with the ballistic update (speed never below 0).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from vilma.world.states import YAW, V, X, Y

CHUNK = 8
"""Path segments per bounding box: a body farther than half a lane from a chunk's box is not near its segments."""

A_MAX, B, HEADWAY, S0, DELTA, LANE_WIDTH, EGO_HALF, T0, PERIOD = range(9)
"""Indices of :attr:`IdmArrays.consts`: IDM's parameters (:class:`~vilma.world.reactive.IdmParams`), the ego's
half length [m], the recording's time at sim time 0 [s] and the period [s]."""


class IdmArrays(NamedTuple):
    """What the period step works on: ``m`` cars along paths of ``k`` points, ``n`` periods of output."""

    consts: np.ndarray
    """(9,): see :data:`A_MAX` .. :data:`PERIOD`."""
    half: np.ndarray
    """Each car's half length [m], (m,)."""
    moving: np.ndarray
    """Whether each drives (a dynamic obstacle recorded at least once), (m,) bool."""
    appear: np.ndarray
    """Each one's first recorded time [s] from the recording's time step 0, (m,)."""
    x: np.ndarray
    """The paths' points [m], (m, k), held after the last recorded one; ``y`` likewise."""
    y: np.ndarray
    yaw: np.ndarray
    """The recorded orientation at each point [rad], unwrapped along the path, (m, k)."""
    speed: np.ndarray
    """The recorded speed at each point [m/s], (m, k): the desired speed there."""
    arc: np.ndarray
    """Arc length at each point [m], (m, k)."""
    bounds: np.ndarray
    """The bounding boxes ``[x min, y min, x max, y max]`` [m] of each path's chunks of :data:`CHUNK` segments,
    (m, ceil((k - 1) / CHUNK), 4) (:func:`chunk_bounds`)."""
    s: np.ndarray
    """Each car's arc position [m], (m,), updated in place."""
    v: np.ndarray
    """Each car's speed [m/s], (m,), updated in place."""
    states: np.ndarray
    """The output: the states at each period, (m, n, 4) (:data:`~vilma.world.states.X` ..), period ``j`` at row
    ``j % n`` (a ring: the last ``n`` periods)."""
    present: np.ndarray
    """Which are on the road at each period, (m, n) bool, as ``states``."""
    j: np.ndarray
    """``[the period the states are filled to]``."""


def chunk_bounds(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """:attr:`IdmArrays.bounds` of the paths through the points ``x``, ``y`` (m, k) [m]."""
    m, k = x.shape
    out = np.empty((m, max(-(-(k - 1) // CHUNK), 0), 4))
    for c in range(out.shape[1]):
        px, py = x[:, c * CHUNK:(c + 1) * CHUNK + 1], y[:, c * CHUNK:(c + 1) * CHUNK + 1]
        out[:, c] = np.stack([px.min(1), py.min(1), px.max(1), py.max(1)], axis=1)
    return out


@njit(cache=True)
def acceleration(c, v, v0, gap, dv):
    """IDM's acceleration [m/s^2] with the parameters ``c`` (:data:`A_MAX` ..) at speed ``v`` [m/s], desired speed
    ``v0`` [m/s], bumper gap ``gap`` [m] (inf: free road) and closing speed ``dv`` [m/s] to the leader."""
    s_star = c[S0] + max(0.0, v * c[HEADWAY] + v * dv / (2 * math.sqrt(c[A_MAX] * c[B])))
    return c[A_MAX] * (1 - (v / v0) ** c[DELTA] - (s_star / max(gap, 1e-3)) ** 2)


@njit(cache=True)
def idm_step(a, ego_x, ego_y, ego_speed):
    """Fill the next period's states of ``a`` (:class:`IdmArrays`) from this one's, the ego's box centre at
    ``ego_x, ego_y`` [m] moving at ``ego_speed`` [m/s] now (over the oldest one when the output is full)."""
    j, c = a.j[0], a.consts
    dt, t = c[PERIOD], c[T0] + j * c[PERIOD]
    for i in range(len(a.s)):
        if not a.moving[i] or t < a.appear[i]:
            continue
        gap, lead_v = _leader(a, i, j, ego_x, ego_y, ego_speed)
        v = a.v[i]
        acc = acceleration(c, v, max(interp(a.s[i] + c[S0], a.arc[i], a.speed[i]), 0.1), gap, v - lead_v)
        v1 = max(v + acc * dt, 0.0)
        a.s[i] += (v + v1) / 2 * dt if v + acc * dt >= 0 else -v * v / (2 * acc)
        a.v[i] = v1
    a.j[0] = j + 1
    place(a, j + 1)


@njit(cache=True)
def place(a, j):
    """Period ``j``'s row of the moving cars' states and presence from their arc positions and speeds."""
    t, row = a.consts[T0] + j * a.consts[PERIOD], j % a.states.shape[1]
    for i in range(len(a.s)):
        if not a.moving[i]:
            continue
        s, st = a.s[i], a.states[i, row]
        st[X], st[Y] = interp(s, a.arc[i], a.x[i]), interp(s, a.arc[i], a.y[i])
        st[YAW] = (interp(s, a.arc[i], a.yaw[i]) + math.pi) % (2 * math.pi) - math.pi
        st[V] = a.v[i]
        # on the road from its first recorded time until it has driven its whole path
        a.present[i, row] = t >= a.appear[i] - 1e-9 and s < a.arc[i, -1] - 1e-6


@njit(cache=True)
def interp(x, xp, fp):
    """``np.interp(x, xp, fp)`` for one ``x`` (``xp`` non-decreasing), without numba's temporary arrays."""
    if x < xp[0]:
        return fp[0]
    if x >= xp[-1]:
        return fp[-1]
    j = np.searchsorted(xp, x, side="right") - 1  # xp[j] <= x < xp[j + 1]
    return fp[j] + (fp[j + 1] - fp[j]) * ((x - xp[j]) / (xp[j + 1] - xp[j]))


@njit(cache=True)
def _leader(a, i, j, ego_x, ego_y, ego_speed):
    """Car ``i``'s bumper gap [m] (inf: none) to, and the speed [m/s] of, the nearest body present at period ``j``
    (the other cars, the ego) ahead on its path within half a lane of it."""
    best, lead_v, reach, j = np.inf, 0.0, a.consts[LANE_WIDTH] / 2, j % a.states.shape[1]
    xs, ys, arc, bounds = a.x[i], a.y[i], a.arc[i], a.bounds[i]  # views taken once: the arguments stay small
    for n in range(len(a.s) + 1):
        ego = n == len(a.s)
        if not ego and (n == i or not a.present[n, j]):
            continue
        px = ego_x if ego else a.states[n, j, X]
        py = ego_y if ego else a.states[n, j, Y]
        lateral, along = _project(xs, ys, arc, bounds, px, py, reach)
        ahead = along - a.s[i]
        gap = ahead - a.half[i] - (a.consts[EGO_HALF] if ego else a.half[n])
        if lateral <= reach and ahead > 0 and gap < best:
            best, lead_v = gap, ego_speed if ego else a.states[n, j, V]
    return best, lead_v


@njit(cache=True)
def _project(xs, ys, arc, bounds, px, py, reach):
    """The distance [m] of the point ``px, py`` from the path through ``xs, ys`` [m] (its chunks' ``bounds``) and
    the arc length ``arc`` [m] of its nearest point (on the first of the nearest segments), if within ``reach``
    [m] of the path (else a distance beyond it)."""
    nearest, along = np.inf, 0.0  # squared distance [m^2]
    for c in range(bounds.shape[0]):
        if px < bounds[c, 0] - reach or px > bounds[c, 2] + reach or py < bounds[c, 1] - reach or \
                py > bounds[c, 3] + reach:
            continue  # farther than reach from each of the chunk's segments: not the nearest within reach
        for k in range(c * CHUNK, min((c + 1) * CHUNK, len(xs) - 1)):
            dx, dy, rx, ry = xs[k + 1] - xs[k], ys[k + 1] - ys[k], px - xs[k], py - ys[k]
            length2 = max(dx * dx + dy * dy, 1e-12)
            f = min(max((rx * dx + ry * dy) / length2, 0.0), 1.0)
            d = (rx - f * dx) ** 2 + (ry - f * dy) ** 2
            if d < nearest:
                nearest, along = d, arc[k] + f * (arc[k + 1] - arc[k])
    return math.sqrt(nearest), along
