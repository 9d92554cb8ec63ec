"""Obstacles' states on the sim clock, compiled (without the roads extra: the flat-ground sensors read them)."""

from __future__ import annotations

import math

from numba import njit

from vilma.core.geometry import wrap

X, Y, YAW, V = range(4)
"""Indices of a state's columns: position [m], orientation [rad, counter-clockwise from +x], speed [m/s]."""


@njit(cache=True)
def states_at(states, present, static, dt, t, out, seen, ring=False):
    """:meth:`Traffic.at <vilma.world.traffic.Traffic.at>` compiled: the states ``states`` (m, k, 4) at time
    ``t`` [s] from time step 0 into ``out`` (m, 4), and which are present into ``seen`` (m,) bool; with
    ``ring``, time step ``i`` is at row ``i % k`` (:attr:`Traffic.ring <vilma.world.traffic.Traffic.ring>`).

    A time within a billionth of a step of a time step is that step's (``t / dt`` rounds off by an ulp either
    way): it reads that step alone, never the next, which reactive traffic fills only a period later."""
    k = states.shape[1]
    s = t / dt
    if abs(s - round(s)) < 1e-9:
        s = float(round(s))
    i = int(max(math.floor(s), 0.0)) if ring else int(min(max(math.floor(s), 0.0), k - 1))
    j = i + 1 if s > i and (ring or i < k - 1) else i
    f = min(max(s - i, 0.0), 1.0) if j > i else 0.0
    inside = s >= 0 and (ring or s <= k - 1)
    i, j = i % k, j % k
    for n in range(states.shape[0]):
        for c in range(4):
            out[n, c] = states[n, i, c] + f * (states[n, j, c] - states[n, i, c])
        out[n, YAW] = wrap(states[n, i, YAW] + f * wrap(states[n, j, YAW] - states[n, i, YAW]))
        seen[n] = static[n] or (inside and present[n, i] and (present[n, j] or f == 0))
