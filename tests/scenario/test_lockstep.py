"""The compiled closed loop drives exactly as the Python loop (the same rows, files and scorecard)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from vilma.app.batch import BUNDLED
from vilma.control.driver import Driver
from vilma.record.run import record_run
from vilma.scenario import load_scenario
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.lockstep import compiled_ok
from vilma.scenario.result import OnReadings
from vilma.scenario.runner import run
from vilma.scenario.spec import TIMING_KEYS
from vilma.sensors.pose import PoseParams
from vilma.sim import Simulator

TIMING = [i for i, c in enumerate(COLUMNS) if c == "controller_us"]


def _same(a, b) -> None:
    keep = [i for i in range(len(COLUMNS)) if i not in TIMING]
    assert a.log.rows.shape == b.log.rows.shape
    assert np.array_equal(a.log.rows[:, keep], b.log.rows[:, keep], equal_nan=True)
    assert {k: v for k, v in a.metrics.items() if k not in TIMING_KEYS} == \
        {k: v for k, v in b.metrics.items() if k not in TIMING_KEYS}


@pytest.mark.slow
@pytest.mark.parametrize(("name", "overrides"), [
    ("course_30kmh_stanley", {}),
    ("course_10kmh_vilma_heading", {}),
    ("fig12_path_pure_pursuit", {"duration": "20"}),
    ("paper_fig11_speed_10", {"duration": "15"}),  # 10 ms driver period, pose at 20 ms, actuation delay
    ("paper_fig12_path", {"driver.original": "true", "duration": "20"}),  # the original's quirks and speed formula
    ("pi_ff_speed_5", {"task": "{go_to: [30, 5], speed: 4}", "plant": "kinematic"}),
    ("course_30kmh_ekf", {}),  # steering by the EKF: the loop measures GPS, IMU and wheel speeds and fuses them
    ("course_30kmh_ekf", {"duration": "30", "plant": "kinematic", "sensors.gps": "{rate_hz: 5, bias_sigma: 0.3}",
                          "sensors.imu": "{rate_hz: 50, offset: [0.5, 0.2, 0.3]}",
                          "sensors.wheel_speed": "{rate_hz: 25}"}),  # other rates, a GPS bias, IMU off the centre
])
def test_compiled_and_python_loops_drive_alike(name, overrides, tmp_path):
    s = load_scenario(BUNDLED / f"{name}.yaml", overrides)
    compiled = record_run(s, tmp_path / "compiled")
    python = record_run(s, tmp_path / "python", compiled=False)
    _same(compiled, python)
    csv = [(tmp_path / loop / "timeseries.csv").read_bytes() for loop in ("compiled", "python")]
    assert csv[0] == csv[1]  # no wall-clock column in it


def _messages(recording: Path) -> list[tuple[str, int, bytes]]:
    """A recording's messages by log time [ns], topic and data (but a plan's and a log row's: they hold wall times)."""
    with recording.open("rb") as f:
        return sorted((m.log_time, c.topic, b"" if c.topic.endswith(("/planning/plan", "/drive_log")) else m.data)
                      for _, c, m in make_reader(f).iter_messages())


@pytest.mark.slow
@pytest.mark.parametrize(("name", "overrides"), [
    ("planned_slower_lead", {}),  # laser perception: scans at each 100 ms, planning cycles 20 ms after them
    ("planned_slower_lead", {"perception": "truth", "duration": "25"}),  # the objects sensor's lists
    ("planned_cut_in", {}),
])
def test_a_planned_run_compiled_up_to_its_cycles_and_scans_drives_and_records_alike(name, overrides, tmp_path):
    s = load_scenario(BUNDLED / f"{name}.yaml", overrides)
    assert compiled_ok(Simulator(s.sim), Driver(s.sim.vehicle, s.driver, step=s.sim.step), planned=True)
    compiled = record_run(s, tmp_path / "compiled", plots=False)
    python = record_run(s, tmp_path / "python", plots=False, compiled=False)
    _same(compiled, python)
    assert [dataclasses.replace(r.planning, cycle_ms=[]) for r in (compiled, python)] == \
        [dataclasses.replace(python.planning, cycle_ms=[])] * 2
    recorded = [_messages(tmp_path / loop / "run.mcap") for loop in ("compiled", "python")]
    assert recorded[0] == recorded[1]
    assert {"perception/objects", "planning/plan"} <= {topic.split("/", 2)[2] for _, topic, _ in recorded[0]}


def test_a_compiled_run_drives_alike_whether_or_not_an_observer_takes_the_readings():
    """Without observers the sensors measure nothing (nobody takes their readings): the drive is the same."""
    s = load_scenario(BUNDLED / "course_30kmh_stanley.yaml", {"duration": "6"})
    taken = []
    alone, observed = run(s), run(s, observers=[OnReadings(taken.append)])
    _same(alone, observed)
    assert len(taken) > 1 and {"gps", "imu"} <= taken[-1].keys()


def test_a_compiled_run_never_runs_the_simulators_frame(monkeypatch):
    """Its first period too goes through the compiled loop's kernel: the frame need not compile (a fresh install)."""
    def no_frame(*args):
        raise AssertionError("the simulator's frame ran")

    monkeypatch.setattr("vilma.sim.simulator.direct", no_frame)
    s = load_scenario(BUNDLED / "course_30kmh_stanley.yaml", {"duration": "3"})
    taken = []
    assert run(s, observers=[OnReadings(taken.append)]).log.rows.shape[0] > 100
    assert {"pose", "imu"} <= taken[0].keys()  # the first period's readings


def test_runs_that_cannot_run_compiled():
    base = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")

    def ok(s) -> bool:
        sim = Simulator(s.sim)
        return compiled_ok(sim, Driver(s.sim.vehicle, s.driver, step=s.sim.step))

    assert ok(base)
    ekf = load_scenario(BUNDLED / "course_30kmh_ekf.yaml")
    assert ok(ekf)
    assert not ok(load_scenario(BUNDLED / "course_30kmh_ekf.yaml", {"sensors.gps": "null"}))  # nothing to fuse
    assert not ok(load_scenario(BUNDLED / "course_30kmh_ekf.yaml", {"driver.original_speed": "true"}))
    noisy = dataclasses.replace(base.sim.sensors, pose=PoseParams(position_noise=0.1))
    assert not ok(dataclasses.replace(base, sim=dataclasses.replace(base.sim, sensors=noisy)))
    dead = dataclasses.replace(base.sim.vehicle.actuators, dead_time=0.05)
    assert not ok(dataclasses.replace(base, sim=dataclasses.replace(
        base.sim, vehicle=dataclasses.replace(base.sim.vehicle, actuators=dead))))
