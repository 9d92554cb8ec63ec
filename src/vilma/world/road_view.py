"""What to draw of a CommonRoad scenario (path.png, the GUI's map, Foxglove): the lanelets' boundaries with their
markings, the goal region and the obstacles' footprints at any sim time, as plain arrays (x, y [m], the file's
frame). The obstacles are read from a :class:`~vilma.world.traffic.Traffic`, the arrays the simulator's sensors
read: the views draw the traffic where the run has it, recorded or reactive. Needs the ``roads`` extra.

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

from vilma.world.commonroad import EgoTask, load
from vilma.world.traffic import Traffic

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
class Placed:
    """An obstacle in the scene at a sim time."""

    id: int
    static: bool
    pose: np.ndarray
    """x, y [m] and yaw [rad]."""
    outline: np.ndarray
    """The shape in the obstacle's frame (p, 2) [m] (x forward)."""

    @property
    def footprint(self) -> np.ndarray:
        """The outline placed at the pose (p, 2) [m]."""
        return place(self.outline, self.pose)

    @property
    def size(self) -> tuple[float, float]:
        """Length and width of the outline's bounding box [m]."""
        return tuple(float(v) for v in self.outline.max(axis=0) - self.outline.min(axis=0))


@dataclass(frozen=True, slots=True, kw_only=True)
class RoadView:
    """A scenario's road, goal and traffic, for drawing."""

    lanelets: tuple[LaneletLines, ...]
    goal: tuple[np.ndarray, ...]
    """The goal region's position shapes, outlines (m, 2) [m] (none for a goal without a position)."""
    traffic: Traffic
    """The obstacles where the run has them: the arrays the simulator's sensors read (filled as it goes when
    the traffic is reactive)."""
    t0: float
    """The traffic's time at sim time 0 [s] from its time step 0."""
    dt: float
    """The file's time step [s]."""

    def at(self, t: float) -> list[Placed]:
        """The obstacles in the scene at sim time ``t`` [s]."""
        tr = self.traffic
        states, present = tr.at(self.t0 + t)
        return [Placed(int(tr.ids[n]), bool(tr.static[n]), states[n, :3], tr.outline[n])
                for n in np.flatnonzero(present).tolist()]

    def paths(self) -> list[np.ndarray]:
        """The moving obstacles' positions (k, 2) [m] at their time steps on the road."""
        tr = self.traffic
        return [tr.states[n, tr.present[n], :2] for n in np.flatnonzero(~tr.static).tolist()]


def place(outline: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``outline`` (m, 2) [m] rotated by ``pose[2]`` [rad] and moved to ``pose[:2]`` [m]."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return outline @ np.array([[c, s], [-s, c]]) + pose[:2]


def road_view(task: EgoTask, traffic: Traffic | None = None, t0: float = 0.0) -> RoadView:
    """What to draw of the CommonRoad file of ``task``, its obstacles as ``traffic`` has them, its time ``t0`` [s]
    at sim time 0 (default: ``task.traffic`` from the initial time step: recorded, or where reactive traffic
    drove)."""
    lanelets, goal = _road(task)
    if traffic is None:
        traffic, t0 = task.traffic, task.time_step * task.dt
    return RoadView(lanelets=lanelets, goal=goal, traffic=traffic, t0=t0, dt=task.dt)


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
