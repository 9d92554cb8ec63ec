"""Runs of real scenarios: the paper's figures, the files, repeatability, and the command line."""

from __future__ import annotations

import json
import math
import resource
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.control.speed.conftest import time_to
from vilma.app.batch import BUNDLED, find_scenario, parse_sets
from vilma.app.cli import main
from vilma.record.reader import read_recording
from vilma.record.run import record_run
from vilma.scenario import SCORECARD_KEYS, load_scenario
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.fields import SpecError
from vilma.scenario.runner import run
from vilma.scenario.spec import TIMING_KEYS
from vilma.trajectory import load_speed_log


def test_paper_fig11_at_10_ms_matches_the_original_log(tmp_path):
    s = load_scenario(BUNDLED / "paper_fig11_speed_10.yaml")
    r = record_run(s, tmp_path)
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


def test_a_resolved_scenario_repeats_byte_for_byte(tmp_path):
    """Two runs differ only in the timing keys: the CSV, the resolved scenario and every other key are equal."""
    s = load_scenario(BUNDLED / "course_30kmh_ekf.yaml", {"duration": "12"})
    first = record_run(s, tmp_path / "a", record=False)
    again = record_run(load_scenario(tmp_path / "a" / "scenario.yaml"), tmp_path / "b", record=False)
    keep = [i for i, c in enumerate(COLUMNS) if c != "controller_us"]
    assert np.array_equal(first.log.rows[:, keep], again.log.rows[:, keep], equal_nan=True)
    csv = (tmp_path / "a" / "timeseries.csv").read_bytes()
    assert csv == (tmp_path / "b" / "timeseries.csv").read_bytes() and b"controller_us" not in csv
    a, b = (json.loads((tmp_path / d / "metrics.json").read_text()) for d in "ab")
    assert {k: v for k, v in a.items() if k not in TIMING_KEYS} == {k: v for k, v in b.items() if k not in TIMING_KEYS}


def test_the_timing_keys_say_what_they_measure(tmp_path):
    """The loop's own time gives the real-time factor; loading compiled code is counted apart; the whole
    command's share holds both and the files."""
    m = record_run(load_scenario(BUNDLED / "pi_ff_speed_5.yaml", {"duration": "6"}), tmp_path, record=False).metrics
    assert m["realtime_factor"] == pytest.approx(m["sim_time_s"] / m["loop_wall_time_s"])
    assert m["load_time_s"] >= 0 and m["wall_time_s"] >= m["loop_wall_time_s"] + m["load_time_s"]


def test_the_papers_steering_losing_the_recorded_track_is_not_completed(tmp_path):
    """Turn-Wheels as shipped (original quirks) on the recorded curve, densified twice, unsmoothed: it drops
    waypoint after waypoint and stops far from the end; the scorecard says so and the run does not pass."""
    p = tmp_path / "lost.yaml"
    p.write_text(f"task: {{follow: {BUNDLED / 'data' / 'PositionLog_curved.txt'}, densify: 2, speed: 5}}\n"
                 "speed_controller: vilma_pid\npath_controller: {type: vilma_heading, original_quirks: true}\n"
                 "duration: 120\nexpect: {completed: true}\n")
    r = run(load_scenario(p))
    m = r.metrics
    end = np.array([r.log.column("x")[-1], r.log.column("y")[-1]])
    assert m["end_error_m"] == pytest.approx(float(np.hypot(*(end - r.path.xy[-1]))))
    assert m["completed"] is False and not r.passed
    assert m["end_error_m"] > 1.0 and m["path_progress"] < 0.95 and m["waypoints_skipped"] > 0
    assert r.failures[0].startswith("completed: no, covered") and "from the end of the path" in r.failures[0]


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
    with pytest.raises(SpecError, match="--set: 1e\\+10 runs in all, more than 100000"):
        parse_sets([f"k{i}=" + ",".join("0123456789") for i in range(10)])  # 10^10 combinations: never built


@pytest.mark.slow
def test_cli_run_sweep_writes_a_folder_per_run(tmp_path, capsys):
    p = tmp_path / "step.yaml"
    p.write_text("task: {speed: 5}\nduration: 4\n")
    out_dir = tmp_path / "runs"
    code = main(["run", str(p), "--set", "seed=1", "--set", "task.speed=4,6", "--out", str(out_dir)])
    out = capsys.readouterr().out
    assert code == 0, out
    assert sorted(p.name for p in out_dir.iterdir()) == ["step-seed_1-task.speed_4", "step-seed_1-task.speed_6"]
    assert "vilma run: summary" in out and "step [seed=1 task.speed=4]" in out  # not taken for markup


def test_cli_run_never_mixes_with_an_earlier_run(tmp_path, capsys):
    p = tmp_path / "step.yaml"
    p.write_text("task: {speed: 5}\ninitial: {speed: 5}\nduration: 2\n")
    out = tmp_path / "o"
    assert main(["run", str(p), "--out", str(out), "--plots"]) == 0
    (out / "notes.txt").write_text("mine")
    capsys.readouterr()
    assert main(["run", str(p), "--out", str(out), "--no-record"]) == 2
    assert "o: holds an earlier run or other files" in capsys.readouterr().err
    assert main(["run", str(p), "--out", str(out), "--no-record", "--overwrite", "--plots"]) == 0
    assert sorted(f.name for f in out.iterdir()) == ["cross_track.png", "effort.png", "metrics.json", "notes.txt",
                                                      "path.png", "scenario.yaml", "speed.png", "timeseries.csv"]


def test_cli_batch_of_runs_with_one_name_keeps_them_all(tmp_path):
    p = tmp_path / "step.yaml"
    p.write_text("task: {speed: 5}\ninitial: {speed: 5}\nduration: 2\n")
    assert main(["run", str(p), "--set", "seed=1,1", "--out", str(tmp_path / "o"), "--no-record"]) == 0
    assert sorted(f.name for f in (tmp_path / "o").iterdir()) == ["step-seed_1", "step-seed_1-2"]


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
def test_ctrl_c_keeps_the_partial_files_and_finishes_the_recording(tmp_path, processes, signum):
    """Ctrl-C, a job scheduler's SIGTERM and a closed terminal's SIGHUP: the same files, one line, 128 + the signal."""
    out = tmp_path / "o"
    # 10 minutes of sim time: Ctrl-C comes long before the end, however slowly this test is scheduled
    p = processes.vilma("run", "pi_ff_speed_5", "--set", "duration=600", "--realtime", "4", "--out", str(out),
                        stderr=subprocess.PIPE)
    part = out / "timeseries.csv.part"
    deadline = time.monotonic() + 120
    while not (part.exists() and part.stat().st_size > 2000) and p.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)  # the loop has written a block: it is driving
    p.send_signal(signum)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 128 + signum, err
    assert err.count("\n") == 1 and err.startswith("vilma run: interrupted at t=") and f"partial files in {out}" in err
    assert sorted(f.name for f in out.iterdir()) == ["run.mcap", "timeseries.csv"]  # no scorecard: not a whole run
    rec = read_recording(out / "run.mcap")
    assert rec.complete and rec.count("pose") > 0


@pytest.mark.slow
def test_a_full_disk_names_the_file(tmp_path, processes):
    """Files may grow to 64 kB only (RLIMIT_FSIZE, as a full disk for this process): one line names the file."""
    run(load_scenario(BUNDLED / "pi_ff_speed_5.yaml", {"duration": "1"}))  # numba's cache written beforehand

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (64_000, 64_000))

    p = processes.vilma("run", "pi_ff_speed_5", "--no-record", "--out", str(tmp_path / "o"), stderr=subprocess.PIPE,
                        preexec_fn=limit)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 1 and err.count("\n") == 1 and "Traceback" not in err  # a failure, not a bad command
    assert "File too large" in err and str(tmp_path / "o" / "timeseries.csv") in err


def test_cli_run_of_an_unfinished_task_shows_why(tmp_path, capsys):
    assert main(["run", "course_30kmh_stanley", "--set", "duration=10", "--out", str(tmp_path / "o")]) == 1
    out = " ".join(capsys.readouterr().out.split())  # the tables wrap long cells
    assert "│ incomplete_reason │ covered" in out and "FAIL course_30kmh_stanley: completed: no, covered" in out


def test_cli_run_exits_1_when_a_scenario_fails_its_expectations(tmp_path, capsys):
    p = tmp_path / "strict.yaml"
    p.write_text("task: {speed: 10}\nduration: 5\nexpect: {completed: false, speed_rise_time_90_s: {max: 1.0}}\n")
    assert main(["run", str(p), "--out", str(tmp_path / "o")]) == 1
    assert "FAIL strict: speed_rise_time_90_s: None is outside max 1" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    (["run", "nope.yaml"], "nope.yaml: no such file, nor a bundled scenario"),
    (["run", "pi_ff_speed_5", "--set", "task.speed"], "--set task.speed: expected key=value"),
    (["run", "pi_ff_speed_5", "--set", "duration=1e9"], "duration: 1000000000 s is more than the 4320000 driver"),
])
def test_cli_bad_input_exits_2_with_one_line(args, message):
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", *args], capture_output=True, text=True)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr and r.stderr.count("\n") == 1 and message in r.stderr


@pytest.mark.slow
def test_demo_tabulates_the_paper_and_vilma(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.count("original program (log)") == 3 and "pi_ff + stanley (ekf pose)" in out and "pi_ff + lqr" in out
    assert len(list(tmp_path.iterdir())) == 14
