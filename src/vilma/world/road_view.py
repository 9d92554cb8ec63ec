"""What to draw of a CommonRoad scenario (path.png, the GUI's map, Foxglove): the lanelets' boundaries with their
markings, the goal region and the obstacles' footprints at any sim time, as plain arrays (x, y [m], the file's
frame). Needs the ``roads`` extra.

Sim time 0 is the planning problem's initial time step; an obstacle's pose between the file's time steps is
interpolated linearly (its yaw along the shorter arc). Dynamic obstacles exist from their initial to their last
time step, static ones always.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from commonroad.geometry.shape import Shape, ShapeGroup
from commonroad.scenario.lanelet import Lanelet, LineMarking
from commonroad.scenario.obstacle import Obstacle, ObstacleRole

from vilma.world.commonroad import EgoTask, load

DASHED = {LineMarking.DASHED, LineMarking.BROAD_DASHED, LineMarking.DASHED_DASHED}
"""Markings drawn dashed (the others, unknown and none included, solid)."""


@dataclass(frozen=True, slots=True)
class LaneletLines:
    """One lanelet: its boundaries (n, 2) [m] and whether each is a dashed marking."""

    id: int
    left: np.ndarray
    right: np.ndarray
    left_dashed: bool
    right_dashed: bool

    @property
    def surface(self) -> np.ndarray:
        """The lanelet's outline (2n, 2) [m]: the left boundary, then the right one backwards."""
        return np.vstack([self.left, self.right[::-1]])


@dataclass(frozen=True, slots=True)
class Body:
    """An obstacle's shape and its poses at the file's time steps."""

    id: int
    outline: np.ndarray
    """The shape in the obstacle's frame (m, 2) [m] (x forward)."""
    size: tuple[float, float]
    """Length and width of the outline's bounding box [m]."""
    static: bool
    t: np.ndarray
    """Sim times of the poses [s], (k,) increasing (one pose for a static obstacle)."""
    pose: np.ndarray
    """x, y [m] and yaw [rad] a time, (k, 3)."""

    def pose_at(self, t: float) -> np.ndarray | None:
        """x, y [m], yaw [rad] at sim time ``t`` [s], or None when the obstacle is not in the scene then."""
        if self.static:
            return self.pose[0]
        if not self.t[0] - 1e-9 <= t <= self.t[-1] + 1e-9:
            return None
        yaw = np.unwrap(self.pose[:, 2])
        return np.array([np.interp(t, self.t, self.pose[:, 0]), np.interp(t, self.t, self.pose[:, 1]),
                         np.interp(t, self.t, yaw)])

    def footprint_at(self, t: float) -> np.ndarray | None:
        """The outline (m, 2) [m] placed at its pose at sim time ``t`` [s], or None when not in the scene."""
        p = self.pose_at(t)
        return None if p is None else place(self.outline, p)


@dataclass(frozen=True, slots=True, kw_only=True)
class RoadView:
    """A scenario's road, goal and traffic, for drawing."""

    lanelets: tuple[LaneletLines, ...]
    goal: tuple[np.ndarray, ...]
    """The goal region's position shapes, outlines (m, 2) [m] (none for a goal without a position)."""
    bodies: tuple[Body, ...]
    dt: float
    """The file's time step [s]."""

    def footprints_at(self, t: float) -> list[tuple[Body, np.ndarray]]:
        """The obstacles in the scene at sim time ``t`` [s] with their footprints (m, 2) [m]."""
        return [(b, f) for b in self.bodies if (f := b.footprint_at(t)) is not None]


def place(outline: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``outline`` (m, 2) [m] rotated by ``pose[2]`` [rad] and moved to ``pose[:2]`` [m]."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return outline @ np.array([[c, s], [-s, c]]) + pose[:2]


def road_view(task: EgoTask) -> RoadView:
    """What to draw of the CommonRoad file of ``task``, its traffic as ``task.scenario`` has it (recorded, or
    where reactive traffic drove)."""
    lanelets, goal = _road(task)
    bodies = tuple(_body(o, task.time_step, task.dt) for o in task.scenario.obstacles)
    return RoadView(lanelets=lanelets, goal=goal, bodies=bodies, dt=task.dt)


@lru_cache(maxsize=4)  # the GUI, the report and the recorder of one run draw the same file
def _road(task: EgoTask) -> tuple[tuple[LaneletLines, ...], tuple[np.ndarray, ...]]:
    """The lanelets and the goal region's outlines of ``task``'s file."""
    lanelets = tuple(_lines(la) for la in load(task.file).network.lanelets.lanelets)
    goal = tuple(_outline(shape) for st in task.goal.state_list if getattr(st, "position", None) is not None
                 for shape in (st.position.shapes if isinstance(st.position, ShapeGroup) else [st.position]))
    return lanelets, goal


def _lines(la: Lanelet) -> LaneletLines:
    return LaneletLines(la.lanelet_id, np.asarray(la.left_vertices, float), np.asarray(la.right_vertices, float),
                        la.line_marking_left_vertices in DASHED, la.line_marking_right_vertices in DASHED)


def _outline(shape: Shape) -> np.ndarray:
    """The outline (m, 2) [m] of a commonroad-io shape (rectangle, circle, polygon), first point not repeated."""
    return np.asarray(shape.shapely_object.exterior.coords, float)[:-1]


def _body(o: Obstacle, t0: int, dt: float) -> Body:
    """An obstacle's outline and poses, its time steps counted from ``t0`` in steps of ``dt`` [s]."""
    static = o.obstacle_role == ObstacleRole.STATIC or o.prediction is None
    states = [o.initial_state]
    if not static and hasattr(o.prediction, "trajectory"):
        states += list(o.prediction.trajectory.state_list)
    t = np.array([(s.time_step - t0) * dt for s in states], float)
    pose = np.array([[*s.position, s.orientation] for s in states], float)
    outline = _outline(o.obstacle_shape)
    size = tuple(float(v) for v in outline.max(axis=0) - outline.min(axis=0))
    return Body(o.obstacle_id, outline, size, static, t, pose)
