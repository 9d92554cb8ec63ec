"""A CommonRoad scenario in the 3D plant: the lanelets' surfaces and markings that the cameras see, and the traffic
as boxes that the laser and the cameras see and the car can hit.

The road is paint on the ground: it does not touch the tyres (they drive on the ground plane below). Each lanelet
is a flat mesh of its outline, each boundary a row of thin white boxes (dashes where the file says). Each obstacle
is a mocap box of its outline's length and width, :data:`TRAFFIC_HEIGHT` tall, that :class:`TrafficMover` puts at
the traffic's pose at the sim time; one not in the scene then waits :data:`AWAY` below the ground.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from vilma.plant3d.world import fmt
from vilma.world.states import YAW, X, Y, states_at

if TYPE_CHECKING:  # the roads extra
    from vilma.world.road_view import LaneletLines
    from vilma.world.traffic import Traffic

ROAD_Z = 0.005
"""Height of the road surface above the ground plane [m] (above it, so the cameras see the road, not the grass)."""
MARK_Z = 0.01
"""Height of the lane markings' top [m] (above the surface)."""
MARK_WIDTH = 0.15
"""Width of a lane marking [m] (a German road's narrow line)."""
DASH, GAP = 3.0, 6.0
"""Length of a dash and of the gap after it [m] (a German town road's dashed line)."""
ROAD_RGBA = (0.25, 0.25, 0.27, 1.0)
MARK_RGBA = (1.0, 1.0, 1.0, 1.0)
TRAFFIC_HEIGHT = 1.5
"""Height of a traffic body [m] (a car's)."""
TRAFFIC_RGBA = (0.75, 0.15, 0.15, 1.0)
PLACES = 9
"""Significant digits of the road's coordinates in the MJCF (a CommonRoad map's are kilometres from its origin)."""
AWAY = -100.0
"""Height of an obstacle's body while it is not in the scene [m] (out of every sensor's sight)."""


def road_xml(lanelets: tuple[LaneletLines, ...]) -> tuple[str, str]:
    """MJCF of the lanelets' surfaces (geoms ``lanelet<id>``) and markings (``marking<k>``): ``(assets, worldbody
    elements)``; a boundary two lanelets share is marked once."""
    assets = "".join(_surface_mesh(la, i) for i, la in enumerate(lanelets))
    surfaces = "".join(f'<geom name="lanelet{la.id}" type="mesh" mesh="lanelet{i}" contype="0" conaffinity="0" '
                       f'rgba="{fmt(*ROAD_RGBA)}"/>' for i, la in enumerate(lanelets))
    seen: set[bytes] = set()
    marks = []
    for la in lanelets:
        for line, dashed in ((la.left, la.left_dashed), (la.right, la.right_dashed)):
            key = min(np.round(line, 2).tobytes(), np.round(line[::-1], 2).tobytes())
            if key not in seen:
                seen.add(key)
                marks += _marking(line, dashed)
    return assets, surfaces + "".join(
        f'<geom name="marking{k}" type="box" contype="0" conaffinity="0" '
        f'size="{fmt(half, MARK_WIDTH / 2, MARK_Z / 2)}" pos="{fmt(x, y, MARK_Z / 2, digits=PLACES)}" '
        f'euler="0 0 {yaw:.6g}" rgba="{fmt(*MARK_RGBA)}"/>'
        for k, (x, y, yaw, half) in enumerate(marks))


def strip_faces(n: int) -> np.ndarray:
    """Triangles (2n - 2, 3) of a strip of ``n`` left vertices (indices 0..n-1) and ``n`` right ones (n..2n-1),
    counter-clockwise seen from above when the left boundary lies left of the right one."""
    i = np.arange(n - 1)
    return np.concatenate([np.stack([i, n + i, i + 1], axis=1), np.stack([i + 1, n + i, n + i + 1], axis=1)])


def _surface_mesh(la: LaneletLines, i: int) -> str:
    """The lanelet's strip between its boundaries (commonroad-io gives both the same number of vertices)."""
    xy = np.vstack([la.left, la.right])
    vertices = np.column_stack([xy, np.full(len(xy), ROAD_Z)])
    return (f'<mesh name="lanelet{i}" inertia="shell" vertex="{fmt(*vertices.ravel(), digits=PLACES)}" '
            f'face="{" ".join(map(str, strip_faces(len(la.left)).ravel()))}"/>')


def _marking(line: np.ndarray, dashed: bool) -> list[tuple[float, float, float, float]]:
    """The boxes of a marking along ``line`` (n, 2) [m]: centre x, y [m], yaw [rad], half length [m]; a solid one
    a box a segment, a dashed one :data:`DASH` on and :data:`GAP` off along the line's length."""
    seg = np.diff(line, axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    keep = length > 1e-6
    a, seg, length = line[:-1][keep], seg[keep], length[keep]
    if not dashed:
        return [(*(p + d / 2), math.atan2(d[1], d[0]), s / 2) for p, d, s in zip(a, seg, length, strict=True)]
    s0 = np.concatenate([[0.0], np.cumsum(length)])
    out = []
    for start in np.arange(0.0, s0[-1], DASH + GAP):
        for k in range(len(seg)):  # the dash's piece on each segment it spans
            lo, hi = max(start, s0[k]), min(start + DASH, s0[k + 1])
            if hi > lo:
                mid = a[k] + seg[k] * ((lo + hi) / 2 - s0[k]) / length[k]
                out.append((*mid, math.atan2(seg[k, 1], seg[k, 0]), (hi - lo) / 2))
    return out


def traffic_xml(traffic: Traffic) -> str:
    """MJCF of the obstacles' bodies, mocap bodies ``traffic<id>`` holding the obstacle geom
    ``obstacle:traffic<id>`` (a box around the outline, standing on the ground)."""
    out = []
    for oid, ring in zip(traffic.ids.tolist(), traffic.outline, strict=True):
        lo, hi = ring.min(axis=0), ring.max(axis=0)
        out.append(f'<body name="traffic{oid}" mocap="true" pos="0 0 {AWAY:g}">'
                   f'<geom name="obstacle:traffic{oid}" type="box" class="obstacle" '
                   f'pos="{fmt(*(lo + hi) / 2, TRAFFIC_HEIGHT / 2)}" size="{fmt(*(hi - lo) / 2, TRAFFIC_HEIGHT / 2)}" '
                   f'rgba="{fmt(*TRAFFIC_RGBA)}"/></body>')
    return "".join(out)


class TrafficMover:
    """Puts the traffic's bodies of a MuJoCo model where the traffic is at a sim time (:func:`move_traffic`, which
    the compiled stepping calls with :attr:`args`)."""

    def __init__(self, model, data, traffic: Traffic, t0: float) -> None:
        """``t0``: the traffic's time at sim time 0 [s] from its time step 0."""
        mocap = np.array([model.body_mocapid[model.body(f"traffic{i}").id] for i in traffic.ids.tolist()])
        m = len(mocap)
        self.args = (traffic.states, traffic.present, traffic.static, np.array([t0, traffic.dt, traffic.ring]),
                     mocap, data.mocap_pos, data.mocap_quat, np.empty((m, 4)), np.empty(m, bool))
        """:func:`move_traffic`'s arguments after the time."""

    def move(self, t: float) -> None:
        """Move the bodies to the traffic at sim time ``t`` [s]."""
        move_traffic(t, *self.args)


@njit(cache=True)
def move_traffic(t, states, present, static, times, mocap, mocap_pos, mocap_quat, out, seen):
    """Put the mocap bodies ``mocap`` where the traffic (its ``states``, ``present``, ``static``; ``times``: its time
    at sim time 0 [s], its step [s], whether it is a ring) is at sim time ``t`` [s], one not present :data:`AWAY`."""
    if len(mocap) == 0:
        return
    states_at(states, present, static, times[1], times[0] + t, out, seen, times[2] != 0.0)
    for k in range(len(mocap)):
        half = out[k, YAW] / 2
        mocap_pos[mocap[k], 0], mocap_pos[mocap[k], 1] = out[k, X], out[k, Y]
        mocap_pos[mocap[k], 2] = 0.0 if seen[k] else AWAY
        mocap_quat[mocap[k], 0], mocap_quat[mocap[k], 1] = math.cos(half), 0.0 * half
        mocap_quat[mocap[k], 2], mocap_quat[mocap[k], 3] = 0.0 * half, math.sin(half)
