"""A drive scored as CommonRoad's benchmark scores it, with ``commonroad-drivability-checker``: collisions with the
scenario's obstacles (its collision checker built from the scenario) and leaving the road (its road-boundary
obstacle), for the ego's own box over the drive sampled at the scenario's time steps; besides, the closest
approach to the traffic and the time to collision.

The road boundary is the checker's ``obb_rectangles`` (thin boxes along the outline of the lanelets' union), closed
at the lanes' ends (``open_lane_ends=False``: the checker's default leaves the start of a lane without predecessor
and the end of one without successor open, so a car driving on past the end of the road would never touch it). The
benchmark's own ``solution_checker`` triangulates the outside instead (the road's ends included), which needs the
non-free ``triangle`` package. A drive that starts on the road and leaves it, over a side or an end, crosses the
outline, so both agree.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import shapely

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    from commonroad_dc import pycrcc
    from commonroad_dc.boundary.boundary import create_road_boundary_obstacle
    from commonroad_dc.collision.collision_detection.pycrcc_collision_dispatch import (
        create_collision_checker,
        create_collision_object,
    )

from vilma.world.commonroad import EgoTask
from vilma.world.traffic import YAW, V, X, Y


@dataclass(frozen=True, slots=True, kw_only=True)
class EgoBox:
    """The ego car's outline: a box ``length`` by ``width`` [m] whose centre is ``offset`` [m] ahead of the
    centre of mass (the drive's reference point)."""

    length: float
    width: float
    offset: float = 0.0


@dataclass(frozen=True, slots=True, kw_only=True)
class DriveCheck:
    """What the benchmark's checks found in a drive (times [s] from the initial state)."""

    hit: tuple[int, ...]
    """The ids of the obstacles the ego touched, in the file's order."""
    collision_time: float | None
    """The first time the ego touched an obstacle, or None."""
    off_road_time: float | None
    """The first time the ego touched the road's boundary, or None."""
    min_distance: float | None
    """The smallest gap between the ego's box and an obstacle's shape [m] (0 touching), None without traffic."""
    min_time_to_collision: float | None
    """The smallest constant-velocity time to collision [s] (:func:`time_to_collision`), None if never closing."""


def check_drive(task: EgoTask, box: EgoBox, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray,
                vx: np.ndarray, vy: np.ndarray) -> DriveCheck:
    """Check a drive: samples at times ``t`` [s] from the initial state of the centre of mass's position [m],
    yaw [rad] and body-frame velocity [m/s], taken at the scenario's time steps (:meth:`EgoTask.samples`)."""
    rows = task.samples(t)
    c, s = np.cos(yaw[rows]), np.sin(yaw[rows])
    cx, cy = x[rows] + box.offset * c, y[rows] + box.offset * s
    boxes = [pycrcc.RectOBB(box.length / 2, box.width / 2, float(a), float(px), float(py))
             for a, px, py in zip(yaw[rows], cx, cy, strict=True)]
    ego = pycrcc.TimeVariantCollisionObject(task.time_step)
    for b in boxes:
        ego.append_obstacle(b)
    hit, collision_time = (), None
    checker = create_collision_checker(task.scenario)
    if boxes and checker.collide(ego):
        hit = tuple(o.obstacle_id for o in task.scenario.obstacles if create_collision_object(o).collide(ego))
        collision_time = _first(boxes, checker.time_slice, task)
    road = create_road_boundary_obstacle(task.scenario, return_scenario_obstacle=False, open_lane_ends=False)
    off_road_time = _first(boxes, lambda k: road, task) if boxes and road.collide(ego) else None
    gap, ttc = _approach(task, box, rows, cx, cy, c, s, vx[rows], vy[rows])
    return DriveCheck(hit=hit, collision_time=collision_time, off_road_time=off_road_time, min_distance=gap,
                      min_time_to_collision=ttc)


def _first(boxes: list, obstacles_at, task: EgoTask) -> float | None:
    """The first time [s] a box of the drive touches ``obstacles_at(time step)``, or None."""
    for k, b in enumerate(boxes):
        if obstacles_at(task.time_step + k).collide(b):
            return k * task.dt
    return None


def _approach(task: EgoTask, box: EgoBox, rows: np.ndarray, cx, cy, c, s, vx, vy) -> tuple[float | None, float | None]:
    """The smallest gap [m] and time to collision [s] to any present obstacle over the drive's time steps."""
    traffic = task.traffic
    steps = task.time_step + np.arange(len(rows))
    xy, present = traffic.polygons(steps)
    if not present.any():
        return None, None
    hl, hw = box.length / 2, box.width / 2
    corners = np.array([[hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw]])
    ex = cx[:, None] + c[:, None] * corners[:, 0] - s[:, None] * corners[:, 1]
    ey = cy[:, None] + s[:, None] * corners[:, 0] + c[:, None] * corners[:, 1]
    ego = shapely.polygons(np.stack([ex, ey], axis=-1))
    gap = np.where(present, shapely.distance(ego[:, None], shapely.polygons(xy)), np.inf)
    k = np.minimum(steps, traffic.states.shape[1] - 1)
    o = traffic.states[:, k].transpose(1, 0, 2)  # (n, m, 4)
    ov = np.stack([o[..., V] * np.cos(o[..., YAW]), o[..., V] * np.sin(o[..., YAW])], axis=-1)
    ev = np.stack([vx * c - vy * s, vx * s + vy * c], axis=-1)[:, None]
    ttc = np.where(present, time_to_collision(gap, o[..., [X, Y]] - np.stack([cx, cy], -1)[:, None], ov - ev),
                   np.inf)
    return _finite_min(gap), _finite_min(ttc)


def time_to_collision(gap: np.ndarray, rel_position: np.ndarray, rel_velocity: np.ndarray) -> np.ndarray:
    """Constant-velocity time to collision along the line of sight [s]: the ``gap`` [m] between the shapes
    over the speed [m/s] at which the centres close along the line joining them, ``-(p . w) / |p|`` for the
    other's position ``p`` and velocity ``w`` relative to the ego (..., 2); infinite when not closing, 0 when
    touching."""
    dist = np.linalg.norm(rel_position, axis=-1)
    closing = -np.sum(rel_position * rel_velocity, axis=-1) / np.where(dist > 0, dist, 1.0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a crawl closes in inf
        return np.where(gap <= 0, 0.0, np.where(closing > 0, gap / closing, np.inf))


def _finite_min(a: np.ndarray) -> float | None:
    m = float(a.min()) if a.size else np.inf
    return m if np.isfinite(m) else None
