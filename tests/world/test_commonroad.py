"""CommonRoad files: the road network's queries against the file's own geometry, the ego's task, bad files."""

from __future__ import annotations

import importlib.resources
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vilma.world.commonroad import CommonRoadError, load

DATA = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad"))
TUTORIAL = DATA / "ZAM_Tutorial-1_1_T-1.xml"  # three adjacent lanes, no speed signs
OVER = DATA / "ZAM_Over-1_1.xml"  # two lanes with a speed limit (format 2018b)


def _points(element) -> np.ndarray:
    return np.array([[float(p.findtext("x")), float(p.findtext("y"))] for p in element.iter("point")])


def _lanelets(path: Path) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Each lanelet's (left, right) boundary as the file writes them."""
    root = ET.parse(path).getroot()
    return {int(e.get("id")): (_points(e.find("leftBound")), _points(e.find("rightBound")))
            for e in root.findall("lanelet")}


def test_a_point_on_a_lanelets_centre_is_on_that_lanelet():
    road = load(TUTORIAL).network
    lanelets = _lanelets(TUTORIAL)
    assert len(road.lanelets.lanelets) == len(lanelets) == 3
    for lid, (left, right) in lanelets.items():
        centre = (left + right) / 2
        for x, y in centre[1:-1:25]:  # inside, away from the lanelet's ends
            assert road.lanelet_at(x, y) == lid


def test_the_road_edge_distance_is_zero_on_the_edge_and_half_a_lane_at_an_outer_lanes_centre():
    road = load(TUTORIAL).network
    lanelets = _lanelets(TUTORIAL)
    left, right = lanelets[1]  # the rightmost lane (lanelet 2 is its left neighbour): its right bound is the edge
    mid = len(right) // 2
    assert road.edge_distance(*right[mid]) == pytest.approx(0.0, abs=1e-9)
    half = np.hypot(*(left[mid] - right[mid])) / 2
    assert road.edge_distance(*((left[mid] + right[mid]) / 2)) == pytest.approx(half, abs=1e-6)
    outward = right[mid] + (right[mid] - left[mid]) / (2 * half)  # 1 m beyond the edge
    assert road.edge_distance(*outward) == pytest.approx(-1.0, abs=1e-6)
    assert road.lanelet_at(*outward) is None


def test_the_road_edges_across_a_path_are_the_outer_lanes_outer_bounds():
    road = load(TUTORIAL).network
    lanelets = _lanelets(TUTORIAL)
    left, right = lanelets[1]  # the rightmost lane; the road's left edge is the leftmost lane's left bound
    top = max(lanelets.values(), key=lambda b: b[0][:, 1].mean())[0]
    centre = (left + right) / 2
    path = centre[5:-5:10]  # along the rightmost lane's centre, away from the road's ends
    to_left, to_right = road.lateral_bounds(path)
    k = np.arange(5, len(centre) - 5, 10)[: len(path)]
    assert np.allclose(to_left, top[k, 1] - path[:, 1], atol=1e-6)  # a straight road along +x: offsets are y's
    assert np.allclose(to_right, right[k, 1] - path[:, 1], atol=1e-6)
    off = road.lateral_bounds(path + np.array([0.0, -50.0]))  # a path off the road has no edges
    assert np.isinf(off).all()


def test_the_route_runs_from_the_initial_position_into_the_goal_region():
    scenario = load(TUTORIAL)
    task = scenario.task()
    pp = scenario.planning_problems[task.planning_problem_id]
    spacing = np.hypot(*np.diff(task.path, axis=0).T).max()
    assert np.hypot(*(task.path[0] - pp.initial_state.position)) <= spacing
    assert any(pp.goal.state_list[0].position.contains_point(p) for p in task.path)
    assert (task.x, task.y, task.yaw, task.speed) == (15.0, 0.0, 0.0, 22.0)  # the file's initialState
    assert np.all(task.path_speed == 22.0)  # no speed sign: the initial speed


def test_a_route_to_where_the_road_ends_stops_the_given_reach_before_the_lanelets_end():
    scenario = load(TUTORIAL)  # a straight road along +x: the route's lanelet has no successor
    lanelet = scenario.network.lanelets.find_lanelet_by_id(scenario.network.lanelet_at(15.0, 0.0))
    assert not lanelet.successor
    end = lanelet.center_vertices[-1]
    assert np.allclose(scenario.task().path[-1], end)  # nothing to keep clear of: the lanelet's end
    path = scenario.task(ahead=3.5).path
    assert np.allclose(path[-1], end - [3.5, 0.0])
    arc = np.hypot(*np.diff(path, axis=0).T)
    assert (arc > 0).all() and np.isclose(arc.sum(), np.hypot(*(end - [3.5, 0.0] - path[0])))


def test_the_path_speed_is_the_lanelets_sign_capped_by_the_task_speed():
    root = ET.parse(OVER).getroot()
    limit = float(root.find("lanelet/speedLimit").text)  # both lanes have the same
    scenario = load(OVER)
    assert np.all(scenario.task().path_speed == limit)
    assert np.all(scenario.task(speed=limit / 2).path_speed == limit / 2)


def test_the_goal_time_is_the_first_step_in_the_goal_region_by_its_own_check():
    scenario = load(TUTORIAL)
    task = scenario.task()
    root = ET.parse(TUTORIAL).getroot()
    goal = root.find("planningProblem/goalState")
    first = int(goal.findtext("time/intervalStart")) * task.dt
    lanelets = _lanelets(TUTORIAL)
    on_goal, off_goal = ((lanelets[i][0][100] + lanelets[i][1][100]) / 2 for i in (1, 3))  # the goal is lanelet 1
    assert goal.find("position/lanelet").get("ref") == "1"
    t = np.arange(0, 6, 0.02)
    ones = np.ones_like(t)
    assert task.goal_time(t, on_goal[0] * ones, on_goal[1] * ones, 0 * ones, 22 * ones) == pytest.approx(first)
    assert task.goal_time(t, off_goal[0] * ones, off_goal[1] * ones, 0 * ones, 22 * ones) is None
    assert task.goal_time(t, on_goal[0] * ones, on_goal[1] * ones, np.pi * ones, 22 * ones) is None  # backwards


def _variant(tmp_path: Path, old: str, new: str, source: Path = TUTORIAL) -> Path:
    p = tmp_path / "s.xml"
    p.write_text(source.read_text().replace(old, new), encoding="utf-8")
    return p


def _one_line(e: pytest.ExceptionInfo, *parts: str) -> None:
    assert "\n" not in str(e.value)
    for part in parts:
        assert part in str(e.value)


def test_bad_files_give_one_line_errors_naming_file_and_element(tmp_path):
    with pytest.raises(CommonRoadError) as e:
        load(tmp_path / "missing.xml")
    _one_line(e, "missing.xml", "no such file")
    with pytest.raises(CommonRoadError) as e:
        load(tmp_path)
    _one_line(e, "not a regular file")
    truncated = tmp_path / "t.xml"
    truncated.write_text(TUTORIAL.read_text()[:3000])
    with pytest.raises(CommonRoadError) as e:
        load(truncated)
    _one_line(e, "t.xml:", "malformed XML")
    with pytest.raises(CommonRoadError) as e:
        load(_variant(tmp_path, 'commonRoadVersion="2020a"', 'commonRoadVersion="1999x"'))
    _one_line(e, "s.xml", "1999x")
    text = TUTORIAL.read_text()
    no_problem = text[:text.index("<planningProblem")] + "</commonRoad>\n"
    (tmp_path / "n.xml").write_text(no_problem)
    with pytest.raises(CommonRoadError) as e:
        load(tmp_path / "n.xml").task()
    _one_line(e, "n.xml", "no planningProblem")
    with pytest.raises(CommonRoadError) as e:
        load(TUTORIAL).task(999)
    _one_line(e, "no planningProblem 999", "ids: 100")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut=st.integers(0, 4000), junk=st.binary(max_size=40))
def test_any_damaged_file_is_read_or_refused_in_one_line(tmp_path, cut, junk):
    raw = TUTORIAL.read_bytes()
    p = tmp_path / "d.xml"
    p.write_bytes(raw[:cut] + junk + raw[cut + len(junk):])
    try:
        load(p)
    except CommonRoadError as e:
        assert "\n" not in str(e) and str(p) in str(e)


def test_the_lanes_are_the_lanelets_centres_and_widths_and_an_object_is_on_the_lane_of_its_direction():
    road = load(OVER).network
    lanes, lanelets = road.lanes, _lanelets(OVER)  # 1000 along +x, 1001 beside it the other way
    ids = [lanelet.lanelet_id for lanelet in road.lanelets.lanelets]
    for i, lid in enumerate(ids):
        left, right = lanelets[lid]
        np.testing.assert_allclose(lanes.centres[i], (left + right) / 2, atol=1e-9)
        half = np.hypot(*(left - right).T) / 2  # a segment's: the wider of its ends'
        np.testing.assert_allclose(lanes.half_width[lanes.lane == i], np.maximum(half[:-1], half[1:]), atol=1e-9)
    assert lanes.successors == ((), ())
    x, y = (lanelets[1000][0][40] + lanelets[1000][1][40]) / 2  # a point on 1000's centre
    heading = math.atan2(*(lanelets[1000][0][41] - lanelets[1000][0][40])[::-1])
    assert ids[lanes.lane[lanes.locate(x, y, heading)]] == 1000
    assert lanes.locate(x, y, heading + math.pi) is None  # against 1000's direction and off 1001
