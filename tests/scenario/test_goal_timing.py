"""A CommonRoad goal's time and speed windows: the route runs on past the route's end, and the speed profile is
timed so that the existing controllers arrive in the windows (checked by the goal's own check)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from commonroad.common.util import Interval
from commonroad.geometry.shape import Rectangle
from commonroad.planning.goal import GoalRegion
from commonroad.planning.planning_problem import PlanningProblem, PlanningProblemSet
from commonroad.scenario.lanelet import Lanelet, LaneletNetwork
from commonroad.scenario.scenario import Scenario, ScenarioID
from commonroad.scenario.state import CustomState, InitialState

from tests.scenario.commonroad_files import write_commonroad
from vilma.scenario import parse_scenario
from vilma.scenario.fields import load_yaml
from vilma.scenario.runner import run
from vilma.world.commonroad import ACROSS_SPACING_M, ACROSS_STEP_M, EXTENSION_M, GOAL_SPACING_M, load

START_X, SPEED = 10.0, 10.0  # the ego's start [m] and speed [m/s]; no sign: the lanelets' speed is the start's
GOAL_X = 60.0  # the goal rectangle's centre [m], 4 m long: 48-52 m of arc from the start


def _lanelet(lid: int, x0: float, x1: float, successor: list[int]) -> Lanelet:
    x = np.linspace(x0, x1, 21)
    return Lanelet(np.c_[x, np.full_like(x, 2.0)], np.c_[x, np.zeros_like(x)], np.c_[x, np.full_like(x, -2.0)],
                   lid, successor=successor)


def _road(tmp_path: Path, time: tuple[int, int], speed: tuple[float, float] | None) -> Path:
    """A straight lane along +x: lanelet 1 (0-100 m) and its successor 2 (100-300 m); the goal a 4 m square at
    GOAL_X in the time steps ``time`` (0.1 s) and speeds ``speed`` [m/s]."""
    sc = Scenario(dt=0.1, scenario_id=ScenarioID(country_id="ZAM", map_name="Timing", map_id=1))
    sc.add_objects(LaneletNetwork.create_from_lanelet_list([_lanelet(1, 0, 100, [2]), _lanelet(2, 100, 300, [])]))
    goal = {"position": Rectangle(4.0, 4.0, np.array([GOAL_X, 0.0])), "time_step": Interval(*time)}
    if speed is not None:
        goal["velocity"] = Interval(*speed)
    init = InitialState(time_step=0, position=np.array([START_X, 0.0]), orientation=0.0, velocity=SPEED,
                        yaw_rate=0.0, slip_angle=0.0)
    pp = PlanningProblem(1, init, GoalRegion([CustomState(**goal)]))
    return write_commonroad(sc, PlanningProblemSet([pp]), tmp_path / "timing.xml")


def _scenario(xml: Path):
    data, src = load_yaml(f"world: {{commonroad: {xml.name}}}\nduration: 40\n", str(xml.parent / "s.yaml"))
    return parse_scenario(data, src, file=xml.parent / "s.yaml")


def test_the_path_runs_on_along_the_lanelet_that_follows_the_route(tmp_path):
    task = load(_road(tmp_path, (50, 60), None)).task()
    assert task.path[0] == pytest.approx([START_X, 0.0], abs=0.1)  # the reference path's point nearest the start
    assert task.path[-1, 0] == pytest.approx(100.0 + EXTENSION_M, abs=10.0)  # centre points every 10 m
    assert task.path[-1, 0] >= 100.0 + EXTENSION_M and np.all(task.path[:, 1] == 0.0)
    (arc, time, speed, across), = task.arrivals
    x0 = task.path[0, 0]
    assert arc == pytest.approx((GOAL_X - 2 - x0, GOAL_X + 2 - x0), abs=GOAL_SPACING_M)
    assert time == pytest.approx((5.0, 6.0)) and speed == (-np.inf, np.inf)
    # the 4 m square across the path along its centre line: 2 m each side all along (its edges are outside)
    s, lo, hi = across
    assert s[0] == arc[0] and s[-1] == arc[1] and np.all(np.diff(s) <= ACROSS_SPACING_M + 1e-9)
    assert lo == pytest.approx(np.full(len(s), -2.0), abs=ACROSS_STEP_M) and np.all(lo > -2.0)
    assert hi == pytest.approx(np.full(len(s), 2.0), abs=ACROSS_STEP_M) and np.all(hi < 2.0)


@pytest.mark.slow
def test_a_late_time_window_is_met_by_slowing_down(tmp_path):
    # at the start's 10 m/s the car would be at the goal at 4.8-5.2 s, before the window of 7-8 s
    m = run(_scenario(_road(tmp_path, (70, 80), (4.0, 9.0)))).metrics
    assert m["goal_reached"] is True and m["completed"] is True, m["incomplete_reason"]
    assert 7.0 <= m["time_to_goal_s"] <= 8.0


@pytest.mark.slow
def test_a_window_no_speed_under_the_limit_meets_is_missed_and_said_so(tmp_path):
    # 50 m in at most 2 s needs 25 m/s, over the 10 m/s the lane allows: the limits are driven, the goal missed
    scenario = _scenario(_road(tmp_path, (10, 20), None))
    assert scenario.reference_path().speed.max() == SPEED
    m = run(scenario).metrics
    assert m["goal_reached"] is False and m["completed"] is False and "goal region" in m["incomplete_reason"]
