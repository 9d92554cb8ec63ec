"""A CommonRoad scenario's road and traffic as Foxglove scene primitives (``foxglove.SceneUpdate``, JSON), for the
recordings and the live view's 3D panel, in the ``map`` frame:

- ``road`` (once, at the start): an entity a lanelet (``lanelet/<id>``) with its boundaries as ``LINE_STRIP``
  lines through the file's vertices (dashed markings grey, the others white; Foxglove draws no dashes) and its
  surface as a triangle list between them, and the goal region's outlines as ``LINE_LOOP`` lines (``goal``).
- ``traffic`` (a frame, every :attr:`~vilma.world.road_view.RoadView.dt`): the obstacles in the scene then,
  a ``CubePrimitive`` each (``obstacle/<id>``, the box of its outline, :data:`OBSTACLE_HEIGHT` high); each update
  first deletes the previous frame's.
"""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING

import numpy as np

from vilma.record.schemas import object_schema

if TYPE_CHECKING:  # the roads extra, which only a road scenario needs
    from vilma.scenario.spec import Scenario
    from vilma.sim import SimConfig
    from vilma.world.road_view import LaneletLines, RoadView

ROAD, TRAFFIC = "road", "traffic"
SCENE_TOPICS = (ROAD, TRAFFIC)
"""The scene topics of a road scenario."""
SCENE_UPDATE = "foxglove.SceneUpdate"
SCENE_SCHEMA = object_schema(SCENE_UPDATE, "Scene entities to draw in the 3D panel (Foxglove's SceneUpdate).", {
    "deletions": {"type": "array", "items": {"type": "object"}},
    "entities": {"type": "array", "items": {"type": "object"}}}, ["deletions", "entities"])
LINE_STRIP, LINE_LOOP = 0, 1
"""``foxglove.LinePrimitive`` types."""
DELETE_ALL = 1
"""``foxglove.SceneEntityDeletion`` type: every entity of the topic."""
ROAD_REPEAT_S = 1.0
"""How often the live view sends the road again [s of sim time] (a client that joins late sees it)."""
OBSTACLE_HEIGHT = 1.5
"""Height of the obstacles' boxes [m] (a CommonRoad shape is a footprint)."""
SOLID, DASHED, SURFACE = (1, 1, 1, 1), (0.6, 0.6, 0.6, 1), (0.35, 0.35, 0.38, 1)
GOAL, MOVING, STANDING = (0.1, 0.8, 0.2, 1), (1, 0.55, 0.1, 0.9), (0.55, 0.55, 0.55, 0.9)
IDENTITY = {"position": {"x": 0, "y": 0, "z": 0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}


def scenario_road(scenario: Scenario | None, sim: SimConfig | None = None) -> RoadView | None:
    """What to draw of ``scenario``'s CommonRoad file, its traffic where the simulator ``sim`` of the run has it
    (default: the scenario's own, recorded), or None when it has none."""
    if scenario is None or scenario.road is None:
        return None
    from vilma.world.road_view import road_view  # the roads extra, which a road scenario has

    sim = sim or scenario.sim
    return road_view(scenario.road, sim.traffic, sim.traffic_t0)


def scene_time(stamp_ns: int) -> dict:
    """A Foxglove ``Time`` of ``stamp_ns`` [ns]."""
    return {"sec": stamp_ns // 1_000_000_000, "nsec": stamp_ns % 1_000_000_000}


def scene_rgba(c) -> dict:
    """A Foxglove ``Color`` of ``c`` (r, g, b, a in 0..1)."""
    return dict(zip("rgba", c, strict=True))


def scene_points(xy: np.ndarray, z: float = 0.0) -> list[dict]:
    """Foxglove ``Point3`` s of ``xy`` (n, 2) [m] at height ``z`` [m]."""
    return [{"x": float(x), "y": float(y), "z": z} for x, y in xy]


def scene_line(xy: np.ndarray, color, kind: int = LINE_STRIP, thickness: float = 0.15, z: float = 0.02) -> dict:
    """A ``foxglove.LinePrimitive`` through the points ``xy`` (n, 2) [m] at height ``z``, ``thickness`` [m] wide."""
    return {"type": kind, "pose": IDENTITY, "thickness": thickness, "scale_invariant": False,
            "points": scene_points(xy, z), "color": scene_rgba(color), "colors": [], "indices": []}


def scene_entity(eid: str, stamp_ns: int, **primitives) -> dict:
    """A Foxglove ``SceneEntity`` ``eid`` in the map frame at ``stamp_ns`` [ns] with ``primitives`` (``lines=[...]``,
    ``cubes=[...]`` ...), none of the other kinds."""
    return {"timestamp": scene_time(stamp_ns), "frame_id": "map", "id": eid, "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": False, "metadata": [], **{k: primitives.get(k, []) for k in (
                "arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models")}}


def _surface(la: LaneletLines) -> dict:
    """The lanelet's surface: two triangles between each pair of boundary points (left i, right i, i + 1)."""
    n = len(la.left)
    i = np.arange(n - 1)
    tri = np.column_stack([i, n + i, i + 1, i + 1, n + i, n + i + 1]).ravel()
    return {"pose": IDENTITY, "points": scene_points(np.vstack([la.left, la.right])), "color": scene_rgba(SURFACE),
            "colors": [], "indices": tri.tolist()}


def road_scene(view: RoadView, stamp_ns: int = 0) -> bytes:
    """The ``road`` update of ``view`` stamped ``stamp_ns`` [ns], JSON."""
    entities = [scene_entity(f"lanelet/{la.id}", stamp_ns, triangles=[_surface(la)], lines=[
        scene_line(la.left, DASHED if la.left_dashed else SOLID),
        scene_line(la.right, DASHED if la.right_dashed else SOLID)])
        for la in view.lanelets]
    if view.goal:
        entities.append(scene_entity("goal", stamp_ns, lines=[scene_line(g, GOAL, LINE_LOOP) for g in view.goal]))
    return json.dumps({"deletions": [], "entities": entities}).encode()


def traffic_scene(view: RoadView, t: float, stamp_ns: int) -> bytes:
    """The ``traffic`` update of ``view`` at sim time ``t`` [s], stamped ``stamp_ns`` [ns], JSON."""
    entities = []
    for body in view.at(t):
        pose = body.pose
        lo, hi = body.outline.min(axis=0), body.outline.max(axis=0)
        c, s = math.cos(pose[2]), math.sin(pose[2])
        mx, my = (lo + hi) / 2
        cube = {"pose": {"position": {"x": pose[0] + c * mx - s * my, "y": pose[1] + s * mx + c * my,
                                      "z": OBSTACLE_HEIGHT / 2},
                         "orientation": {"x": 0, "y": 0, "z": math.sin(pose[2] / 2), "w": math.cos(pose[2] / 2)}},
                "size": {"x": body.size[0], "y": body.size[1], "z": OBSTACLE_HEIGHT},
                "color": scene_rgba(STANDING if body.static else MOVING)}
        entities.append(scene_entity(f"obstacle/{body.id}", stamp_ns, cubes=[cube]))
    return json.dumps({"deletions": [{"timestamp": scene_time(stamp_ns), "type": DELETE_ALL, "id": ""}],
                       "entities": entities}).encode()


def traffic_frames(view: RoadView, t0: float, t1: float) -> list[tuple[int, bytes]]:
    """The ``traffic`` updates (stamp [ns], JSON) at the sim times ``k dt`` [s] in ``[t0, t1)`` (``dt``: the
    file's time step)."""
    dt = view.dt
    ks = range(math.ceil(t0 / dt - 1e-9), math.ceil(t1 / dt - 1e-9))
    return [(round(k * dt * 1e9), traffic_scene(view, k * dt, round(k * dt * 1e9))) for k in ks]


class TrafficFrames:
    """A recording's ``traffic`` updates of ``view`` as sim time goes (:func:`traffic_frames`), each written once;
    after a reset (the time goes back) they start again from there."""

    def __init__(self, view: RoadView) -> None:
        self.view = view
        self.t = 0.0
        """Sim time the frames were taken up to [s] (excluded)."""

    def until(self, t: float) -> list[tuple[int, bytes]]:
        """The frames (stamp [ns], JSON) not yet taken up to sim time ``t`` [s] (excluded)."""
        start, self.t = min(self.t, t), t  # after a reset, from where the time went back to
        return traffic_frames(self.view, start, t)


class SceneFeed:
    """The live view's scene updates of ``view`` as sim time goes: the road every :data:`ROAD_REPEAT_S`, the
    traffic every file time step (both at once again after a reset)."""

    def __init__(self, view: RoadView) -> None:
        self.view = view
        self._road_t = self._traffic_t = -math.inf  # sim times [s] of the last updates sent

    def due(self, stamp_ns: int) -> list[tuple[str, bytes]]:
        """The updates (topic, JSON) due at sim time ``stamp_ns`` [ns]."""
        t, out = stamp_ns / 1e9, []
        if not self._road_t <= t < self._road_t + ROAD_REPEAT_S:
            out.append((ROAD, road_scene(self.view, stamp_ns)))
            self._road_t = t
        if not self._traffic_t <= t < self._traffic_t + self.view.dt - 1e-9:
            out.append((TRAFFIC, traffic_scene(self.view, t, stamp_ns)))
            self._traffic_t = t
        return out
