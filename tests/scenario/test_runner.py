"""Runs of real scenarios: the paper's figures, the files, repeatability, and the command line."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from tests.control.speed.conftest import time_to
from vilma.cli import main
from vilma.scenario import SCORECARD_KEYS, load_scenario
from vilma.scenario.batch import BUNDLED, find_scenario, parse_sets
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.runner import run
from vilma.trajectory import load_speed_log


def test_paper_fig11_at_10_ms_matches_the_original_log(tmp_path):
    s = load_scenario(BUNDLED / "paper_fig11_speed_10.yaml")
    r = run(s, out_dir=tmp_path)
    t_log, v_log = load_speed_log(BUNDLED / "data" / "SpeedLog10.txt")
    assert r.passed and r.metrics["completed"]
    assert r.metrics["speed_rise_time_90_s"] == pytest.approx(time_to(t_log, v_log, 9.0), rel=0.25)
    assert r.metrics["speed_overshoot_pct"] < 6.0
    assert r.metrics["sim_time_s"] == pytest.approx(40.0)
    names = {p.name for p in tmp_path.iterdir()}
    assert {"metrics.json", "timeseries.csv", "scenario.yaml", "path.png", "speed.png", "cross_track.png",
            "effort.png"} <= names
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert list(metrics) == list(SCORECARD_KEYS)
    assert metrics["lateral_error_rms_m"] is None  # a straight-line speed task has no path
    header, *rows = (tmp_path / "timeseries.csv").read_text().splitlines()
    cols = header.split(",")
    assert {"t_s", "car.x", "driver.target_speed", "gps.latitude", "imu.wz", "wheel_speed.rl"} <= set(cols)
    gps = [r for r in rows if r.split(",")[cols.index("gps.x")]]
    assert len(gps) == 40 * 10  # a fix every 100 ms of the 40 s, at its own rate
    assert gps[0].startswith("0.1,")
    imu = [r for r in rows if r.split(",")[cols.index("imu.wz")]]
    driver = [r for r in rows if r.split(",")[cols.index("driver.target_speed")]]
    assert len(imu) == 40 * 100 and len(driver) == len(r.log)  # IMU at 100 Hz, the driver every period


def test_a_resolved_scenario_repeats_bit_for_bit(tmp_path):
    s = load_scenario(BUNDLED / "course_30kmh_ekf.yaml", {"duration": "12"})
    first = run(s, out_dir=tmp_path)
    again = run(load_scenario(tmp_path / "scenario.yaml"))
    keep = [i for i, c in enumerate(COLUMNS) if c != "controller_us"]
    assert np.array_equal(first.log.rows[:, keep], again.log.rows[:, keep], equal_nan=True)


def test_go_to_a_point_stops_on_it(tmp_path):
    p = tmp_path / "go.yaml"
    p.write_text("task: {go_to: [40, 10], speed: 5}\nexpect: {lateral_error_rms_m: {max: 0.2}}\n")
    r = run(load_scenario(p))
    assert r.passed, r.failures
    x, y = r.log.column("x")[-1], r.log.column("y")[-1]
    assert math.hypot(x - 40, y - 10) < 1.0 and abs(r.log.column("vx")[-1]) < 0.05


def test_sweeps_and_bundled_names():
    assert parse_sets(["a=1,2", "b=x,y"]) == [{"a": "1", "b": "x"}, {"a": "1", "b": "y"}, {"a": "2", "b": "x"},
                                             {"a": "2", "b": "y"}]
    assert parse_sets(["task.course=[[0, 0], [1, 1]]"]) == [{"task.course": "[[0, 0], [1, 1]]"}]
    assert find_scenario("paper_fig12_path") == BUNDLED / "paper_fig12_path.yaml"


def test_cli_run_sweep_writes_a_folder_per_run(tmp_path, capsys):
    p = tmp_path / "step.yaml"
    p.write_text("task: {speed: 5}\nduration: 4\n")
    out_dir = tmp_path / "runs"
    code = main(["run", str(p), "--set", "seed=1", "--set", "task.speed=4,6", "--out", str(out_dir)])
    out = capsys.readouterr().out
    assert code == 0, out
    assert sorted(p.name for p in out_dir.iterdir()) == ["step-seed_1-task.speed_4", "step-seed_1-task.speed_6"]
    assert "vilma run: summary" in out


def test_cli_run_exits_1_when_a_scenario_fails_its_expectations(tmp_path, capsys):
    p = tmp_path / "strict.yaml"
    p.write_text("task: {speed: 10}\nduration: 5\nexpect: {speed_rise_time_90_s: {max: 1.0}}\n")
    assert main(["run", str(p), "--out", str(tmp_path / "o")]) == 1
    assert "FAIL strict: speed_rise_time_90_s: None is outside max 1" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    (["run", "nope.yaml"], "nope.yaml: no such scenario file, nor a bundled scenario"),
    (["run", "pi_ff_speed_5", "--set", "task.speed"], "--set task.speed: expected key=value"),
    (["run", "pi_ff_speed_5", "--realtime", "-1"], "--realtime must be a positive factor"),
])
def test_cli_bad_input_exits_2_with_one_line(args, message):
    r = subprocess.run([sys.executable, "-m", "vilma.cli", *args], capture_output=True, text=True)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr and r.stderr.count("\n") == 1 and message in r.stderr


@pytest.mark.slow
def test_demo_tabulates_the_paper_and_vilma(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.count("original program (log)") == 3 and "pi_ff + stanley (ekf pose)" in out
    assert len(list(tmp_path.iterdir())) == 13
