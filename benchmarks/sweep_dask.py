"""Sweeps on Dask (issue 22): a 200-run seed sweep of ``course_30kmh_stanley`` on a local Dask cluster of 2 worker
processes against 1, and the engine's overhead per run against the same runs one after another in this process
(:func:`vilma.scenario.runner.run`); prints JSON.

- ``runs_per_second``: the sweep (:func:`vilma.app.sweep.sweep`, no files) on an already started cluster, median of
  ``ROUNDS``; target: 2 workers at least 1.7 times 1 worker.
- ``overhead_ms_per_run``: (1 worker's sweep - the runs in this process) / runs; target under 20 ms.

    python benchmarks/sweep_dask.py [ROUNDS]
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import time

from distributed import LocalCluster

from vilma.app.sweep import sweep
from vilma.app.sweep_plan import plan_runs
from vilma.scenario.runner import run

RUNS = 200
SCENARIO = "course_30kmh_stanley"
RATIO_TARGET, OVERHEAD_TARGET_MS = 1.7, 20.0


def _sweep_seconds(runs, address: str) -> float:
    t0 = time.perf_counter()
    table = sweep(runs, scheduler=address)
    assert table["error"].isna().all(), table["error"].dropna().iloc[0]
    return time.perf_counter() - t0


def _alone_seconds(runs) -> float:
    t0 = time.perf_counter()
    for r in runs:
        run(r.scenario)
    return time.perf_counter() - t0


def main(rounds: int) -> None:
    runs = plan_runs([SCENARIO], [], seeds=range(RUNS))
    run(runs[0].scenario)  # compiled here, once, outside the timing
    seconds: dict[str, list[float]] = {"alone": [], "1_worker": [], "2_workers": []}
    for workers in (1, 2):
        with LocalCluster(n_workers=workers, threads_per_worker=1, dashboard_address=":0") as cluster:
            _sweep_seconds(runs[:4], cluster.scheduler_address)  # the workers warm, outside the timing
            for _ in range(rounds):
                seconds[f"{workers}_worker{'s' if workers > 1 else ''}"].append(
                    _sweep_seconds(runs, cluster.scheduler_address))
    for _ in range(rounds):
        seconds["alone"].append(_alone_seconds(runs))
    median = {k: statistics.median(v) for k, v in seconds.items()}
    ratio = median["1_worker"] / median["2_workers"]
    overhead = (median["1_worker"] - median["alone"]) / RUNS * 1e3
    print(json.dumps({"benchmark": "sweep_dask", "scenario": SCENARIO, "runs": RUNS, "rounds": rounds,
                      "cores": os.cpu_count(), "load_average_1min": os.getloadavg()[0],
                      "runs_per_second": {k: round(RUNS / v, 1) for k, v in median.items()},
                      "two_workers_over_one": round(ratio, 2), "ratio_target": RATIO_TARGET,
                      "overhead_ms_per_run": round(overhead, 2), "overhead_target_ms": OVERHEAD_TARGET_MS,
                      "meets": {"ratio": ratio >= RATIO_TARGET, "overhead": overhead < OVERHEAD_TARGET_MS}}, indent=2))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
