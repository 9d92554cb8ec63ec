"""CommonRoad scenarios end to end: `vilma run FILE.xml`, a YAML naming one, the goal check, bad input."""

from __future__ import annotations

import importlib.resources
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely import affinity

from vilma.app.cli import main
from vilma.scenario import SpecError, load_scenario, parse_scenario
from vilma.scenario.fields import load_yaml
from vilma.scenario.runner import run
from vilma.world.commonroad import load

DATA = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad"))
TUTORIAL = DATA / "ZAM_Tutorial-1_1_T-1.xml"


def _yaml(text: str, tmp_path: Path):
    data, src = load_yaml(text, str(tmp_path / "s.yaml"))
    return parse_scenario(data, src, file=tmp_path / "s.yaml")


def test_a_commonroad_file_is_a_scenario_with_the_planning_problems_task():
    assert load_scenario(TUTORIAL).task.kind == "plan"  # planned by default; the route followed when set
    s = load_scenario(TUTORIAL, {"task.route": "true"})
    assert s.task.kind == "route"
    assert (s.initial.x, s.initial.y, s.initial.yaw, s.initial.speed) == (15.0, 0.0, 0.0, 22.0)  # its initialState
    assert (s.driver.speed_controller, s.driver.path_controller, s.sim.model) == ("pi_ff", "stanley", "single_track")
    path, d = s.reference_path(), s.driver.stop_deceleration
    # the lane's speed (no sign: the initial 22 m/s; the goal's time window met with it), braking to the end
    np.testing.assert_allclose(path.speed, np.minimum(22.0, np.sqrt(2 * d * (path.s[-1] - path.s))), rtol=1e-9)


@pytest.mark.slow
def test_on_a_road_whose_traffic_stays_out_of_the_lane_the_controllers_reach_the_goal_cleanly():
    result = run(load_scenario("commonroad_tutorial"))  # the recorded car changes lanes behind the ego
    m = result.metrics
    assert m["goal_reached"] is True and m["completed"] is True, m["incomplete_reason"]
    assert m["traffic"] == "recorded" and m["collisions_checked"] is True
    assert m["collisions"] == 0 and m["off_road"] is False and m["min_distance_to_traffic_m"] > 0
    assert result.passed


@pytest.mark.slow
def test_driving_the_route_through_an_obstacle_in_the_lane_is_scored_as_a_collision():
    result = run(load_scenario("commonroad_overtaking"))
    m = result.metrics
    obstacle = result.scenario.road.scenario.obstacles[0]  # standing in the lane the route keeps to
    assert m["goal_reached"] is True and m["collisions"] == 1 and m["min_distance_to_traffic_m"] == 0.0
    assert m["completed"] is False and f"collided with obstacle {obstacle.obstacle_id}" in m["incomplete_reason"]
    c, car, task = result.log.column, result.scenario.sim.vehicle, result.scenario.road
    body = shapely.box(car.body_offset - car.length / 2, -car.width / 2, car.body_offset + car.length / 2,
                       car.width / 2)
    shape = obstacle.occupancy_at_time(0).shape.shapely_object
    first = next(k for k, i in enumerate(task.samples(c("t"))) if affinity.translate(
        affinity.rotate(body, c("yaw")[i], origin=(0, 0), use_radians=True), c("x")[i], c("y")[i]).intersects(shape))
    assert f"(first at {first * task.dt:.3g} s)" in m["incomplete_reason"]  # when the car's box met the obstacle's
    assert result.passed  # its expect block says so


@pytest.mark.slow
def test_the_t_junction_is_reached_inside_its_goals_time_and_speed_windows():
    result = run(load_scenario("commonroad_tjunction"))
    m, task = result.metrics, result.scenario.road
    (goal,) = task.goal.state_list  # the file's goal: lanelet 50203 at steps 146-147, at most 10.63 m/s
    assert (goal.time_step.start, goal.time_step.end) == (146, 147) and goal.velocity.end < 14.0  # 14: the limit
    assert m["goal_reached"] is True and m["completed"] is True and m["collisions"] == 0, m["incomplete_reason"]
    assert 14.6 - 1e-9 <= m["time_to_goal_s"] <= 14.7 + 1e-9
    c = result.log.column
    i = task.samples(c("t"))[round(m["time_to_goal_s"] / task.dt)]
    assert abs(c("vx")[i]) <= goal.velocity.end and result.passed


@pytest.mark.slow
def test_the_run_writes_its_drive_as_a_solution_commonroad_io_reads_back(tmp_path):
    from commonroad.common.solution import CommonRoadSolutionReader, VehicleModel, VehicleType

    out = tmp_path / "out"
    assert main(["run", str(TUTORIAL), "--out", str(out), "--no-record", "--set", "task.route=true"]) == 0
    solution = CommonRoadSolutionReader.open(str(out / "solution.xml"))
    assert str(solution.scenario_id) == "ZAM_Tutorial-1_1_T-1"
    (pp,) = solution.planning_problem_solutions
    assert (pp.planning_problem_id, pp.vehicle_model, pp.vehicle_type) == (100, VehicleModel.ST,
                                                                           VehicleType.FORD_ESCORT)
    states = pp.trajectory.state_list
    first = states[0]
    assert (first.time_step, *first.position, first.orientation, first.velocity) == (0, 15.0, 0.0, 0.0, 22.0)
    rows = np.genfromtxt(out / "timeseries.csv", delimiter=",", names=True, usecols=range(8))
    rows = rows[~np.isnan(rows["carx"])]  # the plant's rows, at the driver's period
    assert len(states) == math.floor(rows["t_s"][-1] / 0.1 + 1e-9) + 1  # every step up to the end of the run
    for st in states[1:]:
        r = rows[np.argmin(np.abs(rows["t_s"] - st.time_step * 0.1))]
        assert r["t_s"] == pytest.approx(st.time_step * 0.1)
        got = (*st.position, st.orientation, st.velocity, st.yaw_rate, st.steering_angle)
        want = (r["carx"], r["cary"], r["caryaw"], math.hypot(r["carvx"], r["carvy"]), r["caryaw_rate"],
                r["carsteer"])
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    from commonroad.planning.planning_problem import PlanningProblemSet
    from commonroad_dc.costs.evaluation import CostFunctionEvaluator  # the benchmark's cost function takes it

    road = load(TUTORIAL)
    problems = PlanningProblemSet(list(road.planning_problems.values()))
    with warnings.catch_warnings():  # its shapely calls use an argument shapely deprecates
        warnings.simplefilter("ignore", DeprecationWarning)
        costs = CostFunctionEvaluator.init_from_solution(solution).evaluate_solution(road.scenario, problems,
                                                                                     solution)
    assert math.isfinite(costs.total_costs)


def test_a_yaml_scenario_names_a_file_and_caps_the_speed(tmp_path):
    s = _yaml(f"world: {{commonroad: {TUTORIAL}, planning_problem: 100}}\ntask: {{route: true, speed: 10}}\n"
              "vehicle: bmw_320i\nseed: 3\n", tmp_path)
    path, d = s.reference_path(), s.driver.stop_deceleration
    ramp = path.s < (22.0 ** 2 - 10.0 ** 2) / (2 * d)  # from the initial 22 m/s down to the cap at d
    np.testing.assert_allclose(path.speed[ramp], np.sqrt(22.0 ** 2 - 2 * d * path.s[ramp]), rtol=1e-9)
    assert np.all(path.speed[~ramp] <= 10.0) and np.any(path.speed[~ramp] == 10.0)
    assert s.sim.seed == 3 and s.road.planning_problem_id == 100


def test_a_route_task_without_a_commonroad_world_is_refused(tmp_path):
    with pytest.raises(SpecError, match=r"s.yaml:1: task.route: a route needs a CommonRoad scenario"):
        _yaml("task: {route: true}\n", tmp_path)


@pytest.mark.parametrize("task", ["{speed: 10}", "{go_to: [50, 0], speed: 5}", "{course: [[0, 0], [9, 0]], speed: 5}",
                                  "{plan: true, course: [[0, 0], [9, 0]], speed: 5}"])
def test_a_task_off_the_planning_problem_on_a_commonroad_world_is_refused_not_driven_without_the_road(tmp_path, task):
    with pytest.raises(SpecError, match=r"s.yaml:2: task: a .* does not drive a CommonRoad world's planning problem"):
        _yaml(f"world: {{commonroad: {TUTORIAL}}}\ntask: {task}\n", tmp_path)


def test_a_speed_set_on_a_commonroad_file_caps_its_default_plan_and_a_kind_set_replaces_it(tmp_path):
    s = load_scenario(TUTORIAL, {"task.speed": "10"})
    assert (s.task.kind, s.task.speed) == ("plan", 10.0) and s.road is not None  # the road, its traffic and goal
    path = s.reference_path()  # the lane's speed capped at 10 m/s, after the start's 22 m/s ramps down to it
    cruise = path.speed[path.s >= (22.0 ** 2 - 10.0 ** 2) / (2 * s.driver.stop_deceleration)]
    assert np.all(cruise <= 10.0) and np.any(cruise == 10.0)
    assert load_scenario(TUTORIAL, {"task.route": "true", "task.speed": "10"}).task.kind == "route"
    road = tmp_path / "s.yaml"  # a YAML road without a task: its route, capped alike
    road.write_text(f"world: {{commonroad: {TUTORIAL}}}\n")
    assert (load_scenario(road, {"task.speed": "10"}).task.kind, load_scenario(road).task.kind) == ("route", "route")
    assert load_scenario(road, {"task.speed": "10"}).task.speed == 10.0


def test_a_gain_set_without_a_type_tunes_the_scenarios_controller(tmp_path):
    d = load_scenario(TUTORIAL, {"speed_controller.kp": "2.5", "path_controller.gain": "3"}).driver  # none named
    assert (d.speed_controller, d.path_controller) == ("pi_ff", "stanley")  # the defaults, their gains set
    assert d.gains_of("pi_ff").kp == 2.5 and d.gains_of("stanley").gain == 3.0
    d = _yaml("task: {speed: 5}\nspeed_controller: vilma_pid\npath_controller: {gain: 2}\n", tmp_path).driver
    assert (d.speed_controller, d.path_controller, d.gains_of("stanley").gain) == ("vilma_pid", "stanley", 2.0)


def test_a_misspelt_planning_problem_key_is_named_with_the_commonroad_keys(tmp_path):
    with pytest.raises(SpecError, match=r"world.planing_problem: unknown key; did you mean 'planning_problem'\? "
                                        r"\(known: .*commonroad, planning_problem\)"):
        _yaml(f"world: {{commonroad: {TUTORIAL}, planing_problem: 100}}\n", tmp_path)


def test_an_unknown_planning_problem_names_the_file_and_the_ids(tmp_path):
    with pytest.raises(SpecError, match=r"ZAM_Tutorial-1_1_T-1.xml: no planningProblem 7 \(ids: 100\)"):
        _yaml(f"world: {{commonroad: {TUTORIAL}, planning_problem: 7}}\n", tmp_path)


@pytest.mark.parametrize(("old", "new", "error"), [
    ("<x>2.25</x>", "<x>nan</x>", "obstacle 42 at time step 0: position is not a finite number"),
    ("<y>3.49399533049</y>", "<y>inf</y>", "obstacle 42 at time step 1: position is not a finite number"),  # its path
    ("<length>4.5</length>", "<length>inf</length>", "obstacle 42: shape is not a finite number"),
    ("<exact>22.0</exact>", "<exact>nan</exact>", "planningProblem 100's initialState: velocity is not a finite"),
    ("<exact>22.0</exact>", "<exact>-5.0</exact>", "planningProblem 100's initialState: velocity -5.0 m/s"),
    ("<x>15</x>", "<x>5000</x>", "planningProblem 100: the initialState's position [5000.0, 0.0] is on no lanelet"),
    ("<goalState>", "<!--", "planningProblem 100 has no goalState"),
])
def test_a_file_with_numbers_or_states_no_drive_can_use_is_refused_by_name(tmp_path, old, new, error):
    road, problem = TUTORIAL.read_text(encoding="utf-8").split("<planningProblem")  # the 42 first, then the 100
    road, problem = (road.replace(old, new, 1), problem) if old in road else (road, problem.replace(old, new, 1))
    bad = tmp_path / "bad.xml"
    bad.write_text(f"{road}<planningProblem{problem.replace('</goalState>', '-->') if new == '<!--' else problem}",
                   encoding="utf-8")
    with pytest.raises(SpecError, match=re.escape(f"bad.xml: {error}")):
        load_scenario(bad)


def test_the_cli_exits_2_with_one_line_on_a_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.xml"
    bad.write_text("<commonRoad><lanelet", encoding="utf-8")
    assert main(["run", str(bad), "--out", str(tmp_path / "out"), "--no-record"]) == 2
    err = capsys.readouterr().err.strip()
    assert "bad.xml:1: malformed XML" in err and "\n" not in err and "Traceback" not in err
