"""``traffic: reactive``: a recorded car that never saw the slow ego drives into it as recorded, and brakes behind it
by the Intelligent Driver Model when reactive; the key is for CommonRoad worlds only."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.scenario.commonroad_files import tutorial_with_car
from vilma.scenario import SpecError, parse_scenario, runner
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.fields import load_yaml
from vilma.scenario.result import RunObserver
from vilma.scenario.runner import run
from vilma.scenario.scorecard import TIMING_KEYS
from vilma.world.reactive import IdmParams
from vilma.world.road_view import road_view

EGO_X, EGO_SPEED = 60.0, 3.0  # the ego starts here [m] in the right lane, slow [m/s]
CAR_X, CAR_SPEED = 5.0, 15.0  # the recorded car, behind it in the same lane [m], [m/s]


def _rear_ended(tmp_path: Path) -> Path:
    """The tutorial's road with the ego at EGO_X at EGO_SPEED and a car recorded for 10 s at CAR_SPEED from CAR_X
    in the ego's lane (its own car removed)."""
    k = np.arange(101)
    car = np.column_stack([CAR_X + CAR_SPEED * k * 0.1, np.zeros(len(k)), np.full(len(k), CAR_SPEED)])  # dt 0.1 s
    return tutorial_with_car(tmp_path / "rear_ended.xml", (EGO_X, EGO_SPEED), car)


def _scenario(tmp_path: Path, extra: str):
    xml = _rear_ended(tmp_path)
    text = f"world: {{commonroad: {xml.name}}}\ntask: {{route: true, speed: {EGO_SPEED}}}\nduration: 8\n{extra}"
    data, src = load_yaml(text, str(tmp_path / "s.yaml"))
    return parse_scenario(data, src, file=tmp_path / "s.yaml")


@pytest.mark.slow
def test_a_recorded_car_drives_into_the_slow_ego(tmp_path):
    m = run(_scenario(tmp_path, "traffic: recorded")).metrics
    assert m["traffic"] == "recorded" and m["collisions"] == 1 and m["min_distance_to_traffic_m"] == 0.0


class Captures(RunObserver):
    def __init__(self) -> None:
        self.got: list = []

    def add_captures(self, captures) -> None:
        self.got += captures


@pytest.fixture(scope="module")
def reactive(tmp_path_factory):
    """A reactive run with a noise-free objects sensor, and what its sensors handed on."""
    seen = Captures()
    scenario = _scenario(tmp_path_factory.mktemp("r"), "traffic: reactive\nobjects: {position_noise: 0, "
                                                      "speed_noise: 0, range: 200}")
    return run(scenario, observers=[seen]), seen.got


@pytest.mark.slow
def test_a_reactive_car_brakes_behind_the_slow_ego(reactive):
    result, _ = reactive
    m = result.metrics
    assert m["traffic"] == "reactive" and m["collisions"] == 0
    # IDM keeps at least its standstill gap s0 behind a leader (less the approach's undershoot, < 0.25 m here:
    # tests/world/test_reactive.py)
    assert m["min_distance_to_traffic_m"] >= IdmParams().s0 - 0.25
    car = result.scenario.road.traffic  # where the car drove, as scored: behind the ego, at its speed by then
    x, present = car.states[0, :, 0], car.present[0]
    assert present.any() and x[present].max() < EGO_X + EGO_SPEED * 8


@pytest.mark.slow
def test_the_objects_sensor_sees_the_car_where_it_drove_not_where_it_was_recorded(reactive):
    result, got = reactive
    car = result.scenario.road.traffic
    lists = [msg for name, msg in got if name == "objects"]
    assert lists
    for msg in lists:
        k = round(msg.stamp_ns * 1e-9 / car.dt)
        (o,) = msg.objects
        assert (o.x, o.y, o.speed) == pytest.approx((car.states[0, k, 0], car.states[0, k, 1], car.states[0, k, 3]))
    last = lists[-1]
    assert last.objects[0].x < CAR_X + CAR_SPEED * last.stamp_ns * 1e-9 - 10  # held back by the ego


@pytest.mark.slow
def test_reactive_traffic_drives_alike_in_the_compiled_and_the_python_loop(tmp_path, monkeypatch):
    """Both loops step the same compiled IDM at the same point of each period: the same drive, traffic and scans,
    bit for bit."""
    scenario = _scenario(tmp_path, "traffic: reactive\nobjects: {range: 200}\nlaser: true")
    real, loops, got = runner.run_compiled, [], []

    def spy(*args):
        loops.append(args[-1])  # the traffic it steps
        return real(*args)

    monkeypatch.setattr(runner, "run_compiled", spy)
    for compiled in (True, False):
        seen = Captures()
        got.append((run(scenario, compiled=compiled, observers=[seen]), seen.got))
    assert len(loops) == 1 and loops[0] is not None  # the first ran compiled with the traffic, the second did not
    (fast, fast_seen), (slow, slow_seen) = got
    keep = [i for i, c in enumerate(COLUMNS) if c != "controller_us"]
    assert np.array_equal(fast.log.rows[:, keep], slow.log.rows[:, keep], equal_nan=True)
    a, b = fast.scenario.road.traffic, slow.scenario.road.traffic
    assert np.array_equal(a.states, b.states) and np.array_equal(a.present, b.present)
    assert fast_seen == slow_seen and {n for n, _ in fast_seen} == {"laser", "objects"}
    assert {k: v for k, v in fast.metrics.items() if k not in TIMING_KEYS} == \
        {k: v for k, v in slow.metrics.items() if k not in TIMING_KEYS}


def test_traffic_is_refused_without_a_commonroad_world(tmp_path):
    data, src = load_yaml("task: {speed: 5}\ntraffic: reactive\n", str(tmp_path / "s.yaml"))
    with pytest.raises(SpecError, match=r"s.yaml:2: traffic: only for a CommonRoad world") as e:
        parse_scenario(data, src, file=tmp_path / "s.yaml")
    assert "\n" not in str(e.value)


def test_an_unknown_traffic_names_the_choices(tmp_path):
    with pytest.raises(SpecError, match=r"traffic: unknown traffic 'smart'; use one of recorded, reactive"):
        _scenario(tmp_path, "traffic: smart")


@pytest.mark.slow
def test_path_png_draws_the_car_where_it_drove(reactive):
    result, _ = reactive
    car = result.scenario.road.traffic
    view = road_view(result.scenario.road)  # what path.png draws
    for k in np.flatnonzero(car.present[0]):
        (body,) = view.at(k * car.dt - view.t0)
        np.testing.assert_allclose(body.pose, car.states[0, k, :3], atol=1e-9)
