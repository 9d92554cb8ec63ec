"""What is drawn of a CommonRoad file: the lanelets and obstacles as the file writes them, poses between its
time steps."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from vilma.world.commonroad import load
from vilma.world.road_view import place, road_view

from .test_commonroad import OVER, TUTORIAL, _lanelets


def _obstacle(path: Path, tag: str) -> tuple[float, float, list[tuple[int, float, float, float]]]:
    """The first obstacle ``tag`` of the file: length, width, and its states (time step, x, y, orientation)."""
    e = ET.parse(path).getroot().find(tag)
    states = [e.find("initialState"), *e.iter("state")]
    return (float(e.findtext("shape/rectangle/length")), float(e.findtext("shape/rectangle/width")),
            [(int(s.findtext("time/exact")), float(s.findtext("position/point/x")),
              float(s.findtext("position/point/y")), float(s.findtext("orientation/exact"))) for s in states])


def test_the_lanelets_are_the_files_boundaries():
    view = road_view(load(TUTORIAL).task())
    expected = _lanelets(TUTORIAL)
    assert {la.id for la in view.lanelets} == set(expected)
    for la in view.lanelets:
        np.testing.assert_array_equal(la.left, expected[la.id][0])
        np.testing.assert_array_equal(la.right, expected[la.id][1])
        np.testing.assert_array_equal(la.surface, np.vstack([expected[la.id][0], expected[la.id][1][::-1]]))
        assert not la.left_dashed and not la.right_dashed  # the file gives no markings: drawn solid


def test_a_dashed_marking_in_the_file_is_drawn_dashed(tmp_path):
    text = TUTORIAL.read_text()
    at = text.index("</leftBound>")  # the first lanelet's left boundary
    (tmp_path / "dashed.xml").write_text(text[:at] + "<lineMarking>dashed</lineMarking>" + text[at:])
    view = road_view(load(tmp_path / "dashed.xml").task())
    first = min(_lanelets(TUTORIAL))
    assert [(la.id, la.left_dashed, la.right_dashed) for la in view.lanelets if la.left_dashed or la.right_dashed] \
        == [(first, True, False)]


def test_a_dynamic_obstacle_is_at_its_recorded_states_and_midway_between_them():
    task = load(TUTORIAL).task()
    view = road_view(task)
    length, width, states = _obstacle(TUTORIAL, "dynamicObstacle")
    for k, x, y, yaw in states[:5]:
        (body,) = view.at((k - task.time_step) * task.dt)
        assert not body.static and body.size == pytest.approx((length, width))
        np.testing.assert_allclose(body.pose, (x, y, yaw), atol=1e-12)
    (k0, *a), (_, *b) = states[0], states[1]
    np.testing.assert_allclose(view.at((k0 + 0.5) * task.dt)[0].pose, np.add(a, b) / 2, atol=1e-12)
    last = (states[-1][0] - task.time_step) * task.dt
    assert view.at(last + task.dt) == []  # it left the scene with its recording
    corners = sorted(map(tuple, np.round(view.at(0.0)[0].footprint, 9)))  # yaw 0 at the start: axis-aligned
    x0, y0 = states[0][1:3]
    assert corners == sorted((x0 + sx * length / 2, y0 + sy * width / 2) for sx in (-1, 1) for sy in (-1, 1))


def test_a_static_obstacle_stands_at_its_initial_state_at_any_time():
    task = load(OVER).task()
    length, width, ((_, x, y, yaw),) = _obstacle(OVER, "obstacle")
    view = road_view(task)
    for t in (0.0, 3.3, 1e4):
        (body,) = [b for b in view.at(t) if b.static]
        np.testing.assert_allclose(body.pose, (x, y, yaw))
    (body,) = [b for b in view.at(7.0) if b.static]
    corners = np.unique(np.round(body.footprint, 9), axis=0)  # the outline's last vertex may repeat
    np.testing.assert_allclose(corners.mean(axis=0), (x, y), atol=1e-9)
    sides = np.hypot(*np.diff(body.footprint, axis=0, append=body.footprint[:1]).T)
    np.testing.assert_allclose(sorted(sides[sides > 1e-9]), [width, width, length, length])


def test_place_turns_then_moves():
    out = place(np.array([[2.0, 0.0], [0.0, 1.0]]), np.array([10.0, 20.0, math.pi / 2]))
    np.testing.assert_allclose(out, [[10, 22], [9, 20]], atol=1e-12)


def test_the_goal_region_is_the_planning_problems_shapes():
    task = load(TUTORIAL).task()
    expected = [s for st in task.goal.state_list for s in st.position.shapes]
    view = road_view(task)
    assert len(view.goal) == len(expected) > 0
    for outline, shape in zip(view.goal, expected, strict=True):
        assert all(shape.contains_point(p) for p in outline.mean(axis=0, keepdims=True))
