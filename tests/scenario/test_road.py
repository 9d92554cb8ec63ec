"""CommonRoad scenarios end to end: `vilma run FILE.xml`, a YAML naming one, the goal check, bad input."""

from __future__ import annotations

import importlib.resources
from pathlib import Path

import numpy as np
import pytest

from vilma.app.cli import main
from vilma.scenario import SpecError, load_scenario, parse_scenario
from vilma.scenario.fields import load_yaml
from vilma.scenario.runner import run

DATA = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad"))
TUTORIAL = DATA / "ZAM_Tutorial-1_1_T-1.xml"


def _yaml(text: str, tmp_path: Path):
    data, src = load_yaml(text, str(tmp_path / "s.yaml"))
    return parse_scenario(data, src, file=tmp_path / "s.yaml")


def test_a_commonroad_file_is_a_scenario_with_the_planning_problems_task():
    s = load_scenario(TUTORIAL)
    assert s.task.kind == "route"
    assert (s.initial.x, s.initial.y, s.initial.yaw, s.initial.speed) == (15.0, 0.0, 0.0, 22.0)  # its initialState
    assert (s.driver.speed_controller, s.driver.path_controller, s.sim.model) == ("pi_ff", "stanley", "single_track")
    path = s.reference_path()
    assert np.all(path.speed == 22.0)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["commonroad_tutorial", "commonroad_overtaking"])
def test_the_controllers_drive_a_bundled_real_road_into_its_goal(name):
    result = run(load_scenario(name))
    m = result.metrics
    assert m["goal_reached"] is True and m["completed"] is True, m["incomplete_reason"]
    assert m["traffic"] == "not simulated" and m["collisions_checked"] is False  # nobody reads it as collision-free
    assert result.passed


def test_a_yaml_scenario_names_a_file_and_caps_the_speed(tmp_path):
    s = _yaml(f"world: {{commonroad: {TUTORIAL}, planning_problem: 100}}\ntask: {{route: true, speed: 10}}\n"
              "vehicle: bmw_320i\nseed: 3\n", tmp_path)
    assert np.all(s.reference_path().speed == 10.0)
    assert s.sim.seed == 3 and s.road.planning_problem_id == 100


def test_a_route_task_without_a_commonroad_world_is_refused(tmp_path):
    with pytest.raises(SpecError, match=r"s.yaml:1: task.route: a route needs a CommonRoad scenario"):
        _yaml("task: {route: true}\n", tmp_path)


def test_an_unknown_planning_problem_names_the_file_and_the_ids(tmp_path):
    with pytest.raises(SpecError, match=r"ZAM_Tutorial-1_1_T-1.xml: no planningProblem 7 \(ids: 100\)"):
        _yaml(f"world: {{commonroad: {TUTORIAL}, planning_problem: 7}}\n", tmp_path)


def test_the_cli_exits_2_with_one_line_on_a_bad_file(tmp_path, capsys):
    bad = tmp_path / "bad.xml"
    bad.write_text("<commonRoad><lanelet", encoding="utf-8")
    assert main(["run", str(bad), "--out", str(tmp_path / "out"), "--no-record"]) == 2
    err = capsys.readouterr().err.strip()
    assert "bad.xml:1: malformed XML" in err and "\n" not in err and "Traceback" not in err
