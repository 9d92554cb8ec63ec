"""``task: {plan: ...}``: the car drives by its own perception and local plan; the scorecard says how it perceived
and planned. The roads are CommonRoad's tutorial road (three straight lanes along +x, lane centres y = 0, 3.5, 7)
with one car of 4.5 m x 2 m in the ego's lane."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st
from rich.console import Console

from tests.scenario.commonroad_files import TUTORIAL, tutorial_with_car
from vilma.app import batch
from vilma.app.cli import main
from vilma.planning import PlannerParams
from vilma.scenario import SpecError, load_scenario, parse_scenario, planned
from vilma.scenario.fields import load_yaml
from vilma.scenario.result import RunObserver
from vilma.scenario.runner import run
from vilma.vehicle.params import vilma
from vilma.world.commonroad import load
from vilma.world.states import X, Y
from vilma.world.traffic import traffic

DT = 0.1  # the tutorial's time step [s]
CAR_LENGTH, CAR_WIDTH = 4.5, 2.0
EGO = vilma()
D0 = PlannerParams().follow_distance  # Werling's gap to a lead at rest, bumper to bumper [m]
TAU = PlannerParams().time_gap  # and its growth with the lead's speed [s]


def _road(tmp_path: Path, ego_x: float, ego_speed: float, car_x: float, car_speed: float = 0.0) -> Path:
    """The tutorial road with the ego at ``ego_x`` [m] at ``ego_speed`` [m/s] and one car at ``car_x``, parked or
    recorded for 30 s at ``car_speed`` [m/s], both in the lane y = 0 heading +x."""
    k = np.arange(301 if car_speed else 1)
    car = np.column_stack([car_x + car_speed * k * DT, np.zeros(len(k)), np.full(len(k), car_speed)])
    return tutorial_with_car(tmp_path / "road.xml", (ego_x, ego_speed), car, CAR_LENGTH, CAR_WIDTH)


def _cut_in(out: Path) -> Path:
    """The tutorial road with the ego at x = 15 m at 10 m/s in the lane y = 0 and a car recorded for 30 s from
    x = 0 m in the lane y = 3.5 m at 16 m/s: 6 m ahead of the ego's front (the ego kept at 10 m/s), it cuts in over
    2 s (a half cosine across, braking at 4 m/s^2 to 8 m/s) and drives on at 8 m/s. Written to ``out``: the bundled
    ZAM_Tutorial-1_1_T-1_cut_in.xml."""
    front = EGO.body_offset + EGO.length / 2
    t0 = (15.0 + front + 6.0 + CAR_LENGTH / 2) / (16.0 - 10.0)  # when its rear is 6 m ahead of the ego's front
    states, x = [], 0.0
    for k in range(301):
        u = min(max((k * DT - t0) / 2.0, 0.0), 1.0)  # the cut-in's progress
        v = 16.0 - 8.0 * u
        states.append((x, 3.5 * (1 + math.cos(math.pi * u)) / 2, v))
        x += v * DT
    return tutorial_with_car(out, (15.0, 10.0), np.array(states), CAR_LENGTH, CAR_WIDTH)


def _scenario(tmp_path: Path, text: str):
    data, src = load_yaml(text, str(tmp_path / "s.yaml"))
    return parse_scenario(data, src, file=tmp_path / "s.yaml")


def _ego_polygons(log) -> list[shapely.Polygon]:
    """The ego's outline at each logged pose (its body centred ``body_offset`` ahead of the centre of mass)."""
    c = log.column
    out = []
    for x, y, yaw in zip(c("x"), c("y"), c("yaw"), strict=True):
        cx, cy = x + EGO.body_offset * math.cos(yaw), y + EGO.body_offset * math.sin(yaw)
        box = shapely.box(-EGO.length / 2, -EGO.width / 2, EGO.length / 2, EGO.width / 2)
        out.append(shapely.affinity.translate(shapely.affinity.rotate(box, yaw, use_radians=True), cx, cy))
    return out


def _parked(x: float) -> shapely.Polygon:
    return shapely.box(x - CAR_LENGTH / 2, -CAR_WIDTH / 2, x + CAR_LENGTH / 2, CAR_WIDTH / 2)


def test_a_plan_on_a_straight_empty_road_completes_at_the_target_speed(tmp_path):
    # 8 m/s from rest: reached within 16 m at the planner's 2 m/s^2; the stop at the goal is planned from where
    # keeping the speed over the 3 s horizon and braking at 3 m/s^2 would reach it, 8 * 3 + 8^2 / 3 = 45 m before
    r = run(_scenario(tmp_path, "task: {plan: true, course: [[0, 0], [150, 0]], speed: 8}\nduration: 40\n"))
    m, c = r.metrics, r.log.column
    assert m["completed"] and m["end_error_m"] < 1.0
    cruise = (c("x") > 40) & (c("x") < 150 - 45 - 5)
    assert np.abs(c("vx")[cruise] - 8.0).max() < 0.3
    assert m["perception"] == "truth" and m["planner"] == "werling" and m["planning_cycles"] > 0
    assert m["mota"] is None and m["identity_switches"] == 0  # nothing to perceive
    assert m["planning_ms_mean"] > 0 and m["planning_ms_max"] >= m["planning_ms_mean"]


def test_a_plan_stops_at_its_goal_on_the_route(tmp_path):
    r = run(_scenario(tmp_path, "task: {plan: {goal: [60, 2]}, course: [[0, 0], [150, 0]], speed: 8}\nduration: 30\n"))
    c = r.log.column
    assert r.metrics["completed"] and math.hypot(c("x")[-1] - 60.0, c("y")[-1]) < 1.0  # where (60, 2) projects
    with pytest.raises(SpecError, match=r"s.yaml: task: the goal \[-5.0, 0.0\] lies at the route.s start"):
        _scenario(tmp_path, "task: {plan: {goal: [-5, 0]}, course: [[0, 0], [150, 0]], speed: 8}\n").reference_path()


@pytest.mark.slow
def test_a_parked_car_in_the_lane_is_never_touched_and_the_car_stops_behind_it(tmp_path):
    xml = _road(tmp_path, 15.0, 10.0, 60.0)
    r = run(_scenario(tmp_path, f"world: {{commonroad: {xml.name}}}\ntask: {{plan: true, speed: 10}}\n"
                                "planner: {lateral_offsets: [0, 3.5]}\nduration: 12\n"))
    parked = _parked(60.0)
    gaps = [p.distance(parked) for p in _ego_polygons(r.log)]
    assert min(gaps) > 0  # never overlaps it
    c = r.log.column
    stopped_behind = c("x")[-1] < 60.0 and abs(c("vx")[-1]) < r.scenario.driver.rest_speed
    passed = c("x")[-1] > 60.0 + CAR_LENGTH / 2 + EGO.length
    assert stopped_behind or passed
    assert r.metrics["collisions"] == 0 and r.metrics["detection_recall"] == 1.0


@pytest.mark.slow
def test_with_no_free_candidate_the_car_stops_and_the_scorecard_says_why(tmp_path):
    # 10 m/s with the parked car's rear 12 m ahead of the ego's front: stopping D0 behind it takes 7 m, beyond the
    # comfortable 3 m/s^2 (16.7 m to rest); the emergency 8 m/s^2 stops in 6.25 m, clear of it
    front = EGO.body_offset + EGO.length / 2
    car_x = 15.0 + front + 12.0 + CAR_LENGTH / 2
    assert 10.0**2 / (2 * EGO.actuators.max_decel) < 12.0 - 1.0  # less the 1 m driven before the car is first seen
    xml = _road(tmp_path, 15.0, 10.0, car_x)
    r = run(_scenario(tmp_path, f"world: {{commonroad: {xml.name}}}\ntask: {{plan: true, speed: 10}}\n"
                                "planner: {lateral_offsets: [0]}\nduration: 5\n"))
    m = r.metrics
    assert m["planner_fallbacks"] >= 1 and m["planner_reason"].startswith("no free candidate")
    assert m["collisions"] == 0 and abs(r.log.column("vx")[-1]) < r.scenario.driver.rest_speed


@pytest.mark.slow
@pytest.mark.parametrize("perception", ["truth", "laser"])
def test_behind_a_slower_lead_car_it_follows_at_a_safe_gap_and_perception_is_scored(tmp_path, perception):
    lead = 5.0
    xml = _road(tmp_path, 15.0, 10.0, 45.0, lead)
    r = run(_scenario(tmp_path, f"world: {{commonroad: {xml.name}}}\ntask: {{plan: true, speed: 10}}\n"
                                f"planner: {{lateral_offsets: [0]}}\nlaser: true\nperception: {perception}\n"
                                "duration: 15\n"))
    m = r.metrics
    assert m["perception"] == perception and m["collisions"] == 0
    assert m["min_distance_to_traffic_m"] >= D0 + TAU * lead - 1.0  # Werling's gap, less a tracking allowance
    assert 0.0 <= m["mota"] <= 1.0 and m["detection_recall"] > 0.5
    assert m["detection_precision"] > 0.5 and m["identity_switches"] == 0


def test_a_car_behind_is_scored_against_the_objects_sensor_but_not_the_forward_laser(tmp_path):
    # 15 m behind the ego in its lane and slower: within both sensors' reach, outside the laser's 180 degrees ahead
    xml = _road(tmp_path, 30.0, 10.0, 15.0, 5.0)
    m = {p: run(_scenario(tmp_path, f"world: {{commonroad: {xml.name}}}\ntask: {{plan: true, speed: 10}}\n"
                                    f"planner: {{lateral_offsets: [0]}}\nlaser: true\nperception: {p}\nduration: 2\n"
                                    )).metrics for p in ("truth", "laser")}
    assert m["truth"]["detection_recall"] > 0.5  # the objects sensor sees all round
    assert m["laser"]["detection_recall"] is None and m["laser"]["mota"] is None  # nothing there to see: undefined


@pytest.mark.parametrize(("text", "where", "message"), [
    ("perception: radar\n", "s.yaml:2", "unknown perception 'radar'; use one of truth, laser"),
    ("planner: {horizon: -1}\n", "s.yaml:2", "planner horizon must be a finite number > 0"),
    ("perception: laser\n", "s.yaml:2", "laser perception needs the laser sensor"),
    ("planner: {dt: 0.05, replan_period: 0.05}\npath_controller: {type: stanley, period: 0.04}\n", "s.yaml:2",
     "0.05 s is not a whole number of driver periods of 0.04 s"),
    ("planner: {target_speed: 3}\n", "s.yaml:2", "set by the scenario's task.speed"),
])
def test_bad_planning_keys_are_one_line_with_file_and_line(tmp_path, text, where, message):
    with pytest.raises(SpecError) as e:
        _scenario(tmp_path, "task: {plan: true, course: [[0, 0], [50, 0]], speed: 5}\n" + text)
    assert str(e.value).startswith(f"{tmp_path / where}") and message in str(e.value) and "\n" not in str(e.value)


@settings(deadline=None, max_examples=50)
@given(key=st.sampled_from(["horizon", "dt", "replan_period", "comfort_accel", "lane_width"]),
       value=st.one_of(st.floats(max_value=0.0, allow_nan=False), st.booleans(), st.text(max_size=5)))
def test_any_bad_planner_number_is_one_line_at_its_section(tmp_path_factory, key, value):
    tmp = tmp_path_factory.mktemp("planner")
    text = f"task: {{plan: true, course: [[0, 0], [50, 0]], speed: 5}}\nplanner:\n  {key}: {json.dumps(value)}\n"
    with pytest.raises(SpecError) as e:
        _scenario(tmp, text)
    assert str(e.value).startswith(f"{tmp / 's.yaml'}:") and "planner" in str(e.value) and "\n" not in str(e.value)


def test_planning_keys_without_a_plan_are_refused(tmp_path):
    with pytest.raises(SpecError, match=r"s.yaml:2: perception: only for a plan task"):
        _scenario(tmp_path, "task: {speed: 5}\nperception: truth\n")


def test_vilma_run_exits_2_on_a_bad_perception(tmp_path, capsys):
    f = tmp_path / "bad.yaml"
    f.write_text("task: {plan: true, course: [[0, 0], [50, 0]], speed: 5}\nperception: radar\n")
    assert main(["run", str(f), "--no-record", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert f"{f}:2: perception: unknown perception 'radar'" in err and err.count("\n") == 1


def test_a_commonroad_file_is_planned_unless_the_task_is_set(tmp_path):
    xml = _road(tmp_path, 15.0, 10.0, 60.0)
    assert load_scenario(xml).task.kind == "plan" and load_scenario(xml).perception == "truth"
    old = load_scenario(xml, {"task.route": "true"})
    assert old.task.kind == "route" and old.planner is None and old.perception is None


@pytest.mark.slow
def test_vilma_run_of_a_commonroad_file_plans_and_the_summary_names_planner_and_perception(tmp_path):
    xml = _road(tmp_path, 15.0, 10.0, 60.0)
    jobs = batch.plan([str(xml)], ["duration=3"])
    results = batch.run_all(jobs, tmp_path / "out", None, Console(quiet=True), lambda _: (), record=False,
                            plots=False)
    console = Console(record=True, width=300)
    console.print(batch.summary_table(jobs, results))
    text = console.export_text()
    assert "planned by" in text and "werling, truth perception" in text
    m = json.loads((tmp_path / "out" / "metrics.json").read_text())
    assert m["planner"] == "werling" and m["perception"] == "truth" and m["planning_cycles"] >= 3 / 0.1


def test_the_bundled_cut_in_is_the_road_cut_in_writes(tmp_path):
    bundled = traffic(load(TUTORIAL.with_name("ZAM_Tutorial-1_1_T-1_cut_in.xml")).scenario)
    made = traffic(load(_cut_in(tmp_path / "cut_in.xml")).scenario)
    assert np.allclose(bundled.states, made.states) and np.array_equal(bundled.present, made.present)


@pytest.mark.slow
def test_after_a_cut_in_the_gap_never_closes_below_what_braking_from_the_gap_left_loses():
    # the car enters the lane over 2 s from 6 m ahead of the ego's front, braking from 16 to 8 m/s: with the ego at
    # 10 m/s the gap grows by (12 - 10) * 2 m; then closing at 10 - 8 m/s, braking at the planner's comfortable
    # acceleration loses at most 2^2 / (2 * comfort_accel)
    r = run(load_scenario("planned_cut_in"))
    sim, c = r.scenario.sim, r.log.column
    gaps = []
    for t, x in zip(c("t"), c("x"), strict=True):
        states, present = sim.traffic.at(t + sim.traffic_t0)
        if present[0] and abs(states[0, Y]) < CAR_WIDTH / 2 + EGO.width / 2:  # in the ego's lane, overlapping it
            gaps.append(states[0, X] - CAR_LENGTH / 2 - (x + EGO.body_offset + EGO.length / 2))
    assert gaps and min(gaps) >= 6.0 + (12.0 - 10.0) * 2.0 - 2.0**2 / (2 * PlannerParams().comfort_accel)


def test_tracks_and_plans_are_made_into_bus_messages_only_for_observers(monkeypatch):
    s = load_scenario("planned_slower_lead", {"duration": "3"})
    topics = []

    class Taker(RunObserver):
        def add_captures(self, captures):
            topics.extend(topic for topic, _ in captures)

    run(s, observers=[Taker()])
    assert {"perception/objects", "planning/plan"} <= set(topics)

    def unmade(*args, **kwargs):
        raise AssertionError("a bus message made for nobody")

    monkeypatch.setattr(planned, "local_plan", unmade)
    monkeypatch.setattr(planned, "track_list", unmade)
    assert run(s).metrics["planning_cycles"] > 1


@pytest.mark.slow
@pytest.mark.parametrize("name", ["planned_parked_car", "planned_slower_lead", "planned_cut_in",
                                  "planned_cones_30kmh"])
def test_the_bundled_planned_scenarios_meet_their_expectations(name):
    r = run(load_scenario(name))
    assert r.passed, r.failures
