"""The benchmark's checks of a drive, against the geometry: the ego's box and the obstacle's recorded shape
(commonroad-io's occupancy, with shapely), the road's outline (the lanelets' union)."""

from __future__ import annotations

import importlib.resources
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely import affinity

from vilma.vehicle.params import vilma
from vilma.world.benchmark import EgoBox, check_drive, time_to_collision
from vilma.world.commonroad import load

DATA = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad"))
OVER = DATA / "ZAM_Over-1_1.xml"  # a static obstacle (6 m x 3.5 m) stands in the ego's lane
CAR = vilma()
BOX = EgoBox(length=CAR.length, width=CAR.width, offset=CAR.body_offset)


def _drive(task, x, y, yaw):
    """A drive sampled at the scenario's steps 0..n-1 (the log's times), at rest in the body frame."""
    t = np.arange(len(x)) * task.dt
    return t, np.asarray(x, float), np.asarray(y, float), np.asarray(yaw, float), np.zeros(len(x)), np.zeros(len(x))


def _box(x, y, yaw):
    """The ego's outline at a centre of mass ``(x, y)`` [m] and yaw [rad], with shapely."""
    body = shapely.box(-BOX.length / 2 + BOX.offset, -BOX.width / 2, BOX.length / 2 + BOX.offset, BOX.width / 2)
    return affinity.translate(affinity.rotate(body, yaw, origin=(0, 0), use_radians=True), x, y)


def test_driving_at_the_obstacle_collides_at_the_step_its_box_first_touches_the_obstacles_shape():
    road = load(OVER)
    task, obstacle = road.task(), road.scenario.obstacles[0]
    target = obstacle.initial_state.position
    yaw = math.atan2(target[1] - task.y, target[0] - task.x)
    s = np.arange(30) * 2.0  # 20 m/s
    x, y = task.x + s * math.cos(yaw), task.y + s * math.sin(yaw)
    shape = obstacle.occupancy_at_time(0).shape.shapely_object
    first = next(k for k in range(len(s)) if _box(x[k], y[k], yaw).intersects(shape))
    found = check_drive(task, BOX, *_drive(task, x, y, np.full(len(s), yaw)))
    assert found.hit == (obstacle.obstacle_id,)
    assert found.collision_time == pytest.approx(first * task.dt)
    assert found.min_distance == 0.0 and found.min_time_to_collision == 0.0


def test_standing_clear_of_the_obstacle_is_no_collision_and_keeps_the_shapes_gap():
    road = load(OVER)
    task, obstacle = road.task(), road.scenario.obstacles[0]
    n = 5
    found = check_drive(task, BOX, *_drive(task, [task.x] * n, [task.y] * n, [task.yaw] * n))
    gap = _box(task.x, task.y, task.yaw).distance(obstacle.occupancy_at_time(0).shape.shapely_object)
    assert found.hit == () and found.collision_time is None and found.off_road_time is None
    assert found.min_distance == pytest.approx(gap, rel=1e-9)
    assert found.min_time_to_collision is None  # nothing moves: never closing


def test_sliding_sideways_off_the_road_is_off_road_when_the_box_leaves_the_lanelets():
    road = load(OVER)
    task = road.task()
    outline = shapely.unary_union([lanelet.polygon.shapely_object for lanelet in road.network.lanelets.lanelets])
    y = task.y - 0.137 * np.arange(30)  # across the right edge, in steps that never land on it
    boxes = [_box(task.x, yk, 0.0) for yk in y]
    first = next(k for k, b in enumerate(boxes) if not outline.contains(b))
    found = check_drive(task, BOX, *_drive(task, [task.x] * len(y), y, np.zeros(len(y))))
    assert found.off_road_time == pytest.approx(first * task.dt)


def test_time_to_collision_is_the_gap_over_the_closing_speed_along_the_line_of_sight():
    p = np.array([[10.0, 0.0], [10.0, 0.0], [10.0, 0.0], [0.0, 5.0], [3.0, 4.0]])
    w = np.array([[-5.0, 0.0], [5.0, 0.0], [0.0, 3.0], [0.0, -1.0], [-3.0, -4.0]])
    gap = np.array([6.0, 6.0, 6.0, 0.0, 2.5])
    ttc = time_to_collision(gap, p, w)
    assert ttc[0] == pytest.approx(6.0 / 5.0)  # head on
    assert ttc[1] == math.inf and ttc[2] == math.inf  # moving apart, passing across: not closing
    assert ttc[3] == 0.0  # touching
    assert ttc[4] == pytest.approx(2.5 / 5.0)  # closing at |w| = 5 m/s straight along the line of sight


def test_a_closing_speed_too_small_for_the_gap_is_an_infinite_time_to_collision_without_a_warning():
    with np.errstate(all="raise"):  # what numpy would warn of is an error here
        ttc = time_to_collision(np.array([1.0]), np.array([[1.0, 0.0]]), np.array([[-1e-310, 0.0]]))
    assert ttc[0] == math.inf  # 1 m / 1e-310 m/s overflows a double


def test_driving_on_past_the_end_of_the_road_is_off_road_when_the_box_leaves_the_lanelets():
    # the checker's default boundary leaves a lane's end open: a car driving on past the last lanelet never touched it
    road = load(DATA / "ZAM_Tutorial-1_1_T-1.xml")  # a straight road along +x; its lanelets have no successor
    task = road.task()
    outline = shapely.unary_union([lanelet.polygon.shapely_object for lanelet in road.network.lanelets.lanelets])
    end = max(lanelet.center_vertices[-1, 0] for lanelet in road.network.lanelets.lanelets)
    x = end - 20.0 + 1.37 * np.arange(30)  # along the lane and on past its end, in steps that never land on it
    first = next(k for k, xk in enumerate(x) if not outline.contains(_box(xk, task.y, 0.0)))
    assert 0 < first < len(x) - 1
    found = check_drive(task, BOX, *_drive(task, x, [task.y] * len(x), np.zeros(len(x))))
    assert found.off_road_time == pytest.approx(first * task.dt)
