"""A CommonRoad scenario's obstacles on the sim clock, as flat arrays that compiled code can read.

Dynamic obstacles follow their recorded trajectories, interpolated linearly between the file's time steps
(orientation along the shorter arc). As commonroad-io (``Obstacle.occupancy_at_time`` is None there) and the
drivability checker (a time-variant object spans only its recorded steps) have it, a dynamic obstacle is
absent before its first and after its last recorded step; a static obstacle stands at its initial state at
every time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vilma.world.states import YAW, V, X, Y, states_at  # noqa: F401 (V: the columns of Traffic.states, here too)

if TYPE_CHECKING:  # the roads extra, which only :func:`traffic` needs (a flat world's obstacles need none)
    import shapely
    from commonroad.scenario.scenario import Scenario

CIRCLE_SIDES = 16
"""A circular obstacle's outline is the regular polygon of this many sides around it."""


@dataclass(frozen=True, slots=True, kw_only=True)
class Traffic:
    """The obstacles of a scenario: ``m`` obstacles, ``k`` time steps of ``dt`` from time step 0."""

    ids: np.ndarray
    """The obstacles' ids in the file, (m,) int64."""
    static: np.ndarray
    """Whether each stands still at every time (a static obstacle), (m,) bool."""
    outline: np.ndarray
    """Each one's shape in its own frame (x forward), (m, p, 2) [m]: the polygon's vertices counter-clockwise,
    the last repeated up to ``p`` (a repeated vertex adds an edge of zero length)."""
    states: np.ndarray
    """The recorded states at each time step, (m, k, 4): :data:`X`, :data:`Y`, :data:`YAW`, :data:`V`."""
    present: np.ndarray
    """Whether each is on the road at each time step, (m, k) bool."""
    dt: float
    """The time step [s]."""
    ring: bool = False
    """Whether the states hold only the last ``k`` time steps, time step ``i`` at row ``i % k`` (reactive traffic
    of an open-ended run, :class:`~vilma.world.reactive.ReactiveTraffic`)."""

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The states (m, 4) at time ``t`` [s] from time step 0, interpolated, and which are present (m,)."""
        out, present = np.empty((len(self.ids), 4)), np.empty(len(self.ids), bool)
        states_at(self.states, self.present, self.static, self.dt, float(t), out, present, self.ring)
        return out, present

    def polygons(self, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The obstacles' outlines placed at the time steps ``step`` (n,), (n, m, p, 2) [m], and which are
        present (n, m); a step past the recording holds only the static obstacles."""
        k = self.states.shape[1]
        i = np.minimum(step, k - 1)
        s = self.states[:, i].transpose(1, 0, 2)  # (n, m, 4)
        c, sn = np.cos(s[..., YAW])[..., None], np.sin(s[..., YAW])[..., None]
        ox, oy = self.outline[None, ..., 0], self.outline[None, ..., 1]
        xy = np.stack([s[..., X, None] + c * ox - sn * oy, s[..., Y, None] + sn * ox + c * oy], axis=-1)
        present = self.present[:, i].T & ((step < k)[:, None] | self.static[None, :])
        return xy, present


def traffic(scenario: Scenario) -> Traffic:
    """The obstacles of a commonroad-io scenario as :class:`Traffic`; none gives empty arrays (one step)."""
    obstacles = scenario.obstacles
    k = 1 + max((o.prediction.final_time_step for o in obstacles if _moves(o)), default=0)
    m = len(obstacles)
    rings = [_outline(o) for o in obstacles]
    p = max((len(r) for r in rings), default=1)
    outline = np.zeros((m, p, 2))
    states = np.zeros((m, k, 4))
    present = np.zeros((m, k), bool)
    for n, (o, ring) in enumerate(zip(obstacles, rings, strict=True)):
        outline[n] = np.concatenate([ring, np.repeat(ring[-1:], p - len(ring), axis=0)])
        recorded = [o.initial_state, *(o.prediction.trajectory.state_list if _moves(o) else ())]
        for st in recorded:
            if st.time_step < k:
                states[n, st.time_step] = (*st.position, st.orientation, getattr(st, "velocity", 0.0) or 0.0)
                present[n, st.time_step] = True
        if not _moves(o):
            states[n, :] = states[n, o.initial_state.time_step]
            present[n, :] = True
    return Traffic(ids=np.array([o.obstacle_id for o in obstacles], np.int64),
                   static=np.array([not _moves(o) for o in obstacles], bool), outline=outline, states=states,
                   present=present, dt=float(scenario.dt))


def _moves(obstacle) -> bool:
    """Whether the obstacle has a recorded trajectory."""
    from commonroad.scenario.obstacle import DynamicObstacle

    return isinstance(obstacle, DynamicObstacle) and obstacle.prediction is not None and hasattr(
        obstacle.prediction, "trajectory")


def _outline(obstacle) -> np.ndarray:
    """The obstacle's shape in its own frame as a counter-clockwise ring without the closing vertex (q, 2) [m]
    (a shape group as the convex hull of its shapes, which covers them)."""
    import shapely

    shape = obstacle.obstacle_shape
    geom = shapely.unary_union([_polygon(s) for s in getattr(shape, "shapes", [shape])])
    if geom.geom_type != "Polygon":
        geom = geom.convex_hull
    ring = shapely.geometry.polygon.orient(geom, 1.0).exterior.coords
    return np.asarray(ring, float)[:-1]


def _polygon(shape) -> shapely.Polygon:
    """A commonroad-io shape as a polygon; a circle as the 16-gon around it (commonroad-io's own polygon of a
    circle has half its radius)."""
    import shapely
    from commonroad.geometry.shape import Circle

    if isinstance(shape, Circle):
        return shapely.Point(*shape.center).buffer(shape.radius / math.cos(math.pi / CIRCLE_SIDES),
                                                     quad_segs=CIRCLE_SIDES // 4)
    return shape.shapely_object
