"""Closed-loop speed and memory of the scenario runner: prints JSON.

- ``closed_loop``: the bundled ``course_30kmh_stanley`` scenario (dynamic plant, pi_ff + stanley, scorecard) run
  by :func:`vilma.scenario.runner.run`, lockstep, one process: simulated seconds per wall second, median of 5 runs
  (files not written). Nobody takes the sensors' readings there, so they measure nothing (the drive is the same);
  ``closed_loop_every_sensor_measured`` is the same run with an observer that takes every reading (all sensors at
  their default rates, as ``vilma run`` measures them). Targets: >= 1000x (issue 4), >= 5000x (issue 21).
- ``ekf_drive``: the bundled ``course_30kmh_ekf`` scenario (the driver steers by the EKF fusing GPS, IMU and
  wheel speeds) the same way, compiled, beside the same drive in the runner's Python loop (``compiled=False``)
  measured in the same run. Target (issue 21): >= 1000x.
- ``simulator_alone_python_api_20ms_periods``: the simulator alone, advanced from Python in the same 20 ms
  periods (what the closed loop cost before it was compiled); ``benchmarks/sim_speed.py`` has the rest.
- ``one_hour_drive``: peak resident memory of a process that runs a one-hour drive (a speed task on a
  long straight) and writes all its files (timeseries of every sensor, plots, scorecard).
  Target (issue 4): < 300 MB.
"""

from __future__ import annotations

import json
import resource
import statistics
import subprocess
import sys
import time

from vilma.app.batch import BUNDLED
from vilma.record.run import record_run
from vilma.scenario import load_scenario
from vilma.scenario.result import RunObserver
from vilma.scenario.runner import run
from vilma.sim import Simulator

REPEATS = 5


def _closed_loop(name: str = "course_30kmh_stanley", compiled: bool = True, observed: bool = False) -> dict:
    scenario = load_scenario(BUNDLED / f"{name}.yaml")
    observers = [RunObserver()] if observed else []  # takes the readings (and does nothing with them)
    run(scenario, compiled=compiled, observers=observers)  # compile / load the numba caches outside the timing
    rates, us = [], []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        r = run(scenario, compiled=compiled, observers=observers)
        rates.append(r.metrics["sim_time_s"] / (time.perf_counter() - t0))
        us.append(r.metrics["controller_time_per_step_us"])
    return {"scenario": scenario.name, "sim_seconds": r.metrics["sim_time_s"],
            "real_time_factor": round(statistics.median(rates), 1),
            "controller_time_per_step_us": round(statistics.median(us), 1)}


def _ekf_drive() -> dict:
    compiled, python = _closed_loop("course_30kmh_ekf"), _closed_loop("course_30kmh_ekf", compiled=False)
    return {**compiled, "target_real_time_factor": 1000,
            "python_loop_real_time_factor": python["real_time_factor"],
            "speedup_over_python_loop": round(compiled["real_time_factor"] / python["real_time_factor"], 1)}


def _simulator_only() -> float:
    rates = []
    for _ in range(REPEATS):
        sim = Simulator()
        t0 = time.perf_counter()
        for _ in range(1500):
            sim.advance(2)
        rates.append(30.0 / (time.perf_counter() - t0))
    return round(statistics.median(rates), 1)


def _one_hour() -> dict:
    from pathlib import Path

    from vilma.scenario.spec import load_scenario as load

    tmp = Path(sys.argv[2])
    tmp.write_text("task: {speed: 15}\nduration: 3600\n", encoding="utf-8")
    t0 = time.perf_counter()
    r = record_run(load(tmp), tmp.parent / "out")
    size = (tmp.parent / "out" / "timeseries.csv").stat().st_size
    return {"sim_seconds": r.metrics["sim_time_s"], "wall_seconds_with_files": round(time.perf_counter() - t0, 1),
            "log_rows": len(r.log), "timeseries_csv_mb": round(size / 2**20, 1),
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)}


def main() -> None:
    if sys.argv[1:2] == ["--one-hour"]:
        print(json.dumps(_one_hour()))
        return
    import tempfile

    out = {"benchmark": "closed_loop", "closed_loop": _closed_loop(),
           "closed_loop_every_sensor_measured": _closed_loop(observed=True), "ekf_drive": _ekf_drive(),
           "simulator_alone_python_api_20ms_periods": {"real_time_factor": _simulator_only()}}
    with tempfile.TemporaryDirectory() as d:
        hour = subprocess.run([sys.executable, __file__, "--one-hour", f"{d}/hour.yaml"], capture_output=True,
                              text=True, check=True)
    out["one_hour_drive"] = json.loads(hour.stdout)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
