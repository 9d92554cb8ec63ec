"""A planned car's tracks and plans as Foxglove scene primitives (``foxglove.SceneUpdate``, a dict to write as JSON), in
the ``map`` frame, written beside their topics (:data:`~vilma.record.schemas.COMPANIONS`):

- ``perception/objects/scene``, from each :class:`~vilma.core.messages.TrackList`: an entity a track
  (``track/<id>``): its box as a ``CubePrimitive`` (:data:`TRACK_HEIGHT` high), its velocity as an
  ``ArrowPrimitive`` as long as :data:`ARROW_S` of travel, and its id as a ``TextPrimitive`` above it.
- ``planning/plan/scene``, from each :class:`~vilma.core.messages.LocalPlan`: ``LINE_STRIP`` lines, the trajectory
  chosen (``plan/chosen``, thick), the candidates drawn by status (``plan/candidates/free``, ``.../infeasible``,
  ``.../colliding``, thin) and the predicted futures (``prediction/<track id>``, a line a way on its lane).

Each update first deletes the previous one's entities, and each entity lasts :data:`LIFETIME_S`: a planner that
stops leaves nothing stale behind.
"""

from __future__ import annotations

import math

import msgspec
import numpy as np

from vilma.core.messages import LocalPlan, Message, TrackList
from vilma.record.road_scene import (
    DELETE_ALL,
    scene_entity,
    scene_line,
    scene_rgba,
    scene_time,
)
from vilma.record.schemas import OBJECTS_SCENE, PLAN_SCENE

TRACK_HEIGHT = 1.5
"""Height of a track's box [m] (a track is a footprint)."""
ARROW_S = 1.0
"""A velocity arrow is the travel of this long [s]."""
LIFETIME_S = 1.0
"""How long an entity is shown without a newer update [s of sim time]."""
STATUS_NAMES = ("free", "infeasible", "colliding")
"""A candidate's :attr:`~vilma.core.messages.PlannedPath.status` -> its name in entity ids."""
TRACK, CHOSEN, PREDICTED = (0.2, 0.5, 1, 0.8), (0.1, 0.8, 0.2, 1), (0.8, 0.2, 0.8, 1)
CANDIDATE = {"free": (0.6, 0.6, 0.6, 0.4), "infeasible": (1, 0.6, 0.1, 0.6), "colliding": (0.9, 0.1, 0.1, 0.6)}
CHOSEN_WIDTH, PATH_WIDTH = 0.4, 0.08
"""Line thickness [m] of the trajectory chosen and of the other paths."""


def _quaternion(yaw: float) -> dict:
    return {"x": 0, "y": 0, "z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def _strip(x, y, color, thickness: float) -> dict:
    return scene_line(np.column_stack([x, y]), color, thickness=thickness, z=0.05)


def _lasting(entity: dict) -> dict:
    whole = math.floor(LIFETIME_S)
    return {**entity, "lifetime": {"sec": whole, "nsec": round((LIFETIME_S - whole) * 1e9)}}


def _update(stamp_ns: int, entities: list[dict]) -> dict:
    return {"deletions": [{"timestamp": scene_time(stamp_ns), "type": DELETE_ALL, "id": ""}],
            "entities": [_lasting(e) for e in entities]}


def tracks_scene(tracks: TrackList) -> dict:
    """The ``perception/objects/scene`` update of ``tracks`` (see the module docstring)."""
    entities = []
    for o in tracks.objects:
        travel = math.hypot(o.vx, o.vy) * ARROW_S
        cube = {"pose": {"position": {"x": o.x, "y": o.y, "z": TRACK_HEIGHT / 2}, "orientation": _quaternion(o.yaw)},
                "size": {"x": o.length, "y": o.width, "z": TRACK_HEIGHT}, "color": scene_rgba(TRACK)}
        arrow = {"pose": {"position": {"x": o.x, "y": o.y, "z": TRACK_HEIGHT},
                          "orientation": _quaternion(math.atan2(o.vy, o.vx))},
                 "shaft_length": 0.75 * travel, "shaft_diameter": 0.15, "head_length": 0.25 * travel,
                 "head_diameter": 0.4, "color": scene_rgba(TRACK)}
        text = {"pose": {"position": {"x": o.x, "y": o.y, "z": TRACK_HEIGHT + 0.8}, "orientation": _quaternion(0.0)},
                "billboard": True, "font_size": 14, "scale_invariant": True, "color": scene_rgba((1, 1, 1, 1)),
                "text": str(o.id)}
        entities.append(scene_entity(f"track/{o.id}", tracks.stamp_ns, cubes=[cube], arrows=[arrow], texts=[text]))
    return _update(tracks.stamp_ns, entities)


def plan_scene(plan: LocalPlan) -> dict:
    """The ``planning/plan/scene`` update of ``plan`` (see the module docstring)."""
    t = plan.stamp_ns
    entities = [scene_entity("plan/chosen", t, lines=[_strip(plan.x, plan.y, CHOSEN, CHOSEN_WIDTH)])]
    for status, name in enumerate(STATUS_NAMES):
        lines = [_strip(c.x, c.y, CANDIDATE[name], PATH_WIDTH) for c in plan.candidates if c.status == status]
        if lines:
            entities.append(scene_entity(f"plan/candidates/{name}", t, lines=lines))
    futures: dict[int, list] = {}  # a track's futures (one a way on its lane) in one entity
    for p in plan.predictions:
        futures.setdefault(p.id, []).append(_strip(p.x, p.y, PREDICTED, PATH_WIDTH))
    entities += [scene_entity(f"prediction/{i}", t, lines=lines) for i, lines in futures.items()]
    return _update(t, entities)


PLANNING_SCENES = {OBJECTS_SCENE: tracks_scene, PLAN_SCENE: plan_scene}
"""Scene topic -> its update from a message of the topic it is written beside."""


def scene_json(name: str, msg: Message) -> bytes:
    """The update of scene topic ``name`` from ``msg``, JSON."""
    return msgspec.json.encode(PLANNING_SCENES[name](msg))  # a plan's is 100 kB: a quarter of json.dumps's time
