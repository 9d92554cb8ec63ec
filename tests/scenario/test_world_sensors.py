"""The flat-ground laser and the objects sensor in a CommonRoad run: both loops (compiled and Python) hand
their messages to the observers, and what they measure is the file's geometry where the car was."""

from __future__ import annotations

import importlib.resources
import math
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
import shapely

from vilma.core.messages import ObjectList, PointCloud
from vilma.record.reader import read_recording
from vilma.record.run import record_run
from vilma.scenario import SpecError, parse_scenario, runner, to_yaml
from vilma.scenario.fields import load_yaml
from vilma.scenario.result import RunObserver
from vilma.scenario.runner import run

DATA = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad"))
SCENARIO = f"""
world: {{commonroad: {DATA / "ZAM_Over-1_1.xml"}}}
laser: {{max_range: 60}}
objects: {{position_noise: 0, speed_noise: 0}}
duration: 1.0
"""


class Captures(RunObserver):
    def __init__(self) -> None:
        self.got: list = []

    def add_captures(self, captures) -> None:
        self.got += captures


def _yaml(text: str, tmp_path: Path):
    data, src = load_yaml(text, str(tmp_path / "s.yaml"))
    return parse_scenario(data, src, file=tmp_path / "s.yaml")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    scenario = _yaml(SCENARIO, tmp_path_factory.mktemp("s"))
    out = {}
    for compiled in (True, False):
        seen = Captures()
        with mock.patch.object(runner, "run_compiled", wraps=runner.run_compiled) as spy:
            out[compiled] = run(scenario, compiled=compiled, observers=[seen]), seen.got
        assert spy.call_count == compiled  # the compiled loop ran the first, the Python loop the second
    return out


def test_both_loops_hand_on_a_scan_and_an_object_list_each_tenth_of_a_second(runs):
    (result, got), (_, slow) = runs[True], runs[False]
    t0 = result.t_start
    scans = [m for name, m in got if name == "laser"]
    lists = [m for name, m in got if name == "objects"]
    assert all(isinstance(m, PointCloud) for m in scans) and all(isinstance(m, ObjectList) for m in lists)
    expected = [round(k * 1e8) for k in range(1, round((t0 + 1.0) * 10) + 1)]
    assert [m.stamp_ns for m in scans] == [m.stamp_ns for m in lists] == expected
    assert got == slow  # the compiled loop measures what the Python loop does


def test_the_static_obstacle_is_listed_where_the_file_puts_it(runs):
    result, got = runs[True]
    obstacle = result.scenario.road.scenario.obstacles[0]
    s = obstacle.initial_state
    length, width = obstacle.obstacle_shape.length, obstacle.obstacle_shape.width
    for name, m in got:
        if name == "objects":
            (o,) = m.objects
            assert (o.id, o.x, o.y, o.speed) == (obstacle.obstacle_id, *s.position, 0.0)
            assert (o.yaw, o.length, o.width) == pytest.approx((s.orientation, length, width), abs=1e-9)


def test_each_scan_meets_the_obstacle_where_its_rays_cross_its_rectangle(runs):
    result, got = runs[True]
    laser = result.scenario.sim.laser
    shape = result.scenario.road.scenario.obstacles[0].occupancy_at_time(0).shape.shapely_object  # in the world
    t, x, y, yaw = (result.log.column(c) for c in ("t", "x", "y", "yaw"))
    hits = 0
    for name, m in got:
        if name != "laser":
            continue
        i = int(np.argmin(np.abs(t - m.stamp_ns * 1e-9)))
        assert t[i] == pytest.approx(m.stamp_ns * 1e-9, abs=1e-9)  # the log has a row at each scan
        c, s = math.cos(yaw[i]), math.sin(yaw[i])
        (mx, my, _), r_max = laser.position, laser.max_range
        ox, oy = x[i] + mx * c - my * s, y[i] + mx * s + my * c
        ranges = np.frombuffer(m.ranges, "<f4")
        for b, r in zip(laser.bearings, ranges, strict=True):
            ray = shapely.LineString([(ox, oy), (ox + r_max * math.cos(yaw[i] + b), oy + r_max * math.sin(yaw[i] + b))])
            cross = ray.intersection(shape.exterior)
            want = shapely.Point(ox, oy).distance(cross) if not cross.is_empty else math.inf
            assert r == pytest.approx(want, abs=1e-4)
            hits += math.isfinite(want)
    assert hits > 0  # the obstacle ahead is in the scans


def test_a_laser_of_several_layers_on_flat_ground_is_a_one_line_error(tmp_path):
    with pytest.raises(SpecError, match=r"s.yaml.*laser.*one layer") as e:
        _yaml("task: {speed: 5}\nlaser: {layers: [0, 5]}\n", tmp_path)
    assert "\n" not in str(e.value)


def test_bad_objects_fields_are_one_line_errors(tmp_path):
    with pytest.raises(SpecError, match=r"s.yaml.*objects.*range") as e:
        _yaml("task: {speed: 5}\nobjects: {range: -1}\n", tmp_path)
    assert "\n" not in str(e.value)


def test_a_recorded_run_holds_the_scans_and_the_object_lists(tmp_path):
    seen = Captures()
    record_run(_yaml(SCENARIO, tmp_path), tmp_path / "out", observers=[seen])
    rec = read_recording(tmp_path / "out" / "run.mcap")
    assert rec.schemas["objects"] == "vilma.ObjectList" and rec.schemas["laser"] == "sensor_msgs/msg/LaserScan"
    assert rec.messages("objects") == [m for name, m in seen.got if name == "objects"]
    assert rec.messages("laser") == [m for name, m in seen.got if name == "laser"]
    assert rec.count("objects") == rec.count("laser") == len(seen.got) // 2 > 0


def test_the_sensors_and_the_traffic_clock_survive_the_resolved_yaml(tmp_path):
    s = _yaml(SCENARIO, tmp_path)
    assert s.sim.objects.position_noise == 0 and s.sim.laser.max_range == 60
    assert s.sim.traffic is s.road.traffic and s.sim.traffic_t0 == s.road.time_step * s.road.dt
    assert _yaml(to_yaml(s), tmp_path) == s
