"""Traffic on the sim clock: the file's recorded states at its time steps, interpolated between them, absent
where commonroad-io says an obstacle is not there, static obstacles standing."""

from __future__ import annotations

import importlib.resources
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from commonroad.geometry.shape import Circle, Rectangle, ShapeGroup

from vilma.world.commonroad import load
from vilma.world.traffic import Traffic, traffic

DATA = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad"))
TUTORIAL = DATA / "ZAM_Tutorial-1_1_T-1.xml"  # one car recorded for 4 s, changing lanes
OVER = DATA / "ZAM_Over-1_1.xml"  # one static obstacle


def test_a_recorded_car_is_at_its_recorded_states_on_the_time_steps():
    scenario = load(TUTORIAL).scenario
    car = scenario.obstacles[0]
    tr = traffic(scenario)
    assert tr.ids.tolist() == [car.obstacle_id] and tr.dt == scenario.dt
    for k in range(car.prediction.final_time_step + 1):
        state = car.state_at_time(k)
        got, present = tr.at(k * scenario.dt)
        assert present[0]
        np.testing.assert_allclose(got[0], [*state.position, state.orientation, state.velocity], atol=1e-9)


def test_between_two_steps_the_state_is_interpolated_linearly():
    scenario = load(TUTORIAL).scenario
    car, tr = scenario.obstacles[0], traffic(scenario)
    a, b = car.state_at_time(12), car.state_at_time(13)
    got, _ = tr.at(12.25 * scenario.dt)
    np.testing.assert_allclose(got[0, :2], 0.75 * a.position + 0.25 * b.position, atol=1e-9)
    assert got[0, 3] == pytest.approx(0.75 * a.velocity + 0.25 * b.velocity)


def test_at_a_time_step_only_that_step_is_read():
    states = np.zeros((1, 8, 4))
    states[0, 6] = (1.0, 2.0, 0.5, 3.0)
    states[0, 7] = np.nan  # not known yet (reactive traffic fills it a period later)
    tr = Traffic(ids=np.array([1]), static=np.array([False]), outline=np.zeros((1, 1, 2)), states=states,
                 present=np.ones((1, 8), bool), dt=0.1)
    assert 6 * 0.1 / 0.1 > 6  # the time of step 6 divided by the step lands an ulp past it
    got, present = tr.at(6 * 0.1)
    assert got[0].tolist() == [1.0, 2.0, 0.5, 3.0] and present[0]


def test_the_heading_is_interpolated_across_the_half_turn():
    tr = Traffic(ids=np.array([1]), static=np.array([False]), outline=np.zeros((1, 1, 2)),
                 states=np.array([[[0, 0, math.pi - 0.1, 1], [0, 0, -math.pi + 0.1, 1]]]),
                 present=np.ones((1, 2), bool), dt=0.1)
    got, _ = tr.at(0.05)
    assert abs(got[0, 2]) == pytest.approx(math.pi)  # the short way round, not through 0


def test_a_moving_obstacle_is_there_exactly_when_commonroad_io_gives_it_an_occupancy():
    scenario = load(TUTORIAL).scenario
    car, tr = scenario.obstacles[0], traffic(scenario)
    for k in range(car.prediction.final_time_step + 5):
        assert tr.at(k * scenario.dt)[1][0] == (car.occupancy_at_time(k) is not None), k
    assert not tr.at((car.prediction.final_time_step + 0.5) * scenario.dt)[1][0]  # gone after its last step


def test_a_static_obstacle_stands_where_the_file_puts_it_at_every_time():
    scenario = load(OVER).scenario
    obstacle, tr = scenario.obstacles[0], traffic(scenario)
    for t in (0.0, 1.23, 1e4):
        got, present = tr.at(t)
        assert present[0] and tr.static[0]
        np.testing.assert_allclose(got[0, :3], [*obstacle.initial_state.position, obstacle.initial_state.orientation])


def test_the_placed_outlines_are_commonroad_ios_occupancies():
    for file in (TUTORIAL, OVER):
        scenario = load(file).scenario
        tr = traffic(scenario)
        steps = np.array([0, 7, 40])
        xy, present = tr.polygons(steps)
        for n, obstacle in enumerate(scenario.obstacles):
            for j, k in enumerate(steps):
                want = obstacle.occupancy_at_time(int(k)).shape.shapely_object
                got = want.__class__(xy[j, n])
                assert present[j, n] and got.symmetric_difference(want).area < 1e-9


def test_a_file_without_obstacles_has_empty_traffic(tmp_path):
    scenario = load(OVER).scenario
    scenario.remove_obstacle(list(scenario.obstacles))
    tr = traffic(scenario)
    states, present = tr.at(3.0)
    assert tr.ids.shape == (0,) and states.shape == (0, 4) and present.shape == (0,)


def test_a_shape_group_is_covered_by_its_convex_hull():
    scenario = load(OVER).scenario
    obstacle = scenario.obstacles[0]
    parts = [Rectangle(2.0, 1.0), Circle(0.5, center=np.array([3.0, 0.0]))]
    obstacle._obstacle_shape = ShapeGroup(parts)  # commonroad-io checks the type on assignment, not the group
    ring = traffic(scenario).outline[0]
    hull = shapely.Polygon(ring)
    circle = shapely.Point(3.0, 0.0).buffer(0.5 - 1e-9, quad_segs=64)
    assert hull.covers(parts[0].shapely_object.buffer(-1e-9)) and hull.covers(circle)
    covering = 0.5 / math.cos(math.pi / 16)  # the 16-gon around the circle reaches this far along its axes
    assert hull.bounds == pytest.approx((-1.0, -covering, 3.0 + covering, covering))
