"""Batch throughput: a 50-run ``--set`` sweep of ``course_30kmh_stanley`` (seeds 1-50) as one ``vilma run`` command
on one core (the process pinned to CPU 0), with its scorecards, summary table and run folders; prints JSON.

- ``scorecards``: ``--no-record`` (timeseries, scenario and metrics files, the summary);
- ``default_files``: the default files (``run.mcap`` too);
- ``all_files``: ``--plots`` (the four plots too).

Runs per second of the whole command (its start included), median of ``ROUNDS`` interleaved rounds, against the
issue's target of 10 (issue 21; before it, under 0.3).

    python benchmarks/sweep_throughput.py [ROUNDS]
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

RUNS = 50
TARGET = 10.0


def _sweep(out: str, *extra: str) -> float:
    """Runs per second of one sweep command into ``out``, pinned to one core."""
    argv = [sys.executable, "-m", "vilma", "run", "course_30kmh_stanley", "--set",
            "seed=" + ",".join(map(str, range(1, RUNS + 1))), "--out", out, "--overwrite", "-q", *extra]
    t0 = time.perf_counter()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # as installed: modules compiled
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, env=env,
                   preexec_fn=lambda: os.sched_setaffinity(0, {0}))
    return RUNS / (time.perf_counter() - t0)


def main(rounds: int) -> None:
    cases = {"scorecards": ("--no-record",), "default_files": (), "all_files": ("--plots",)}
    rates: dict[str, list[float]] = {k: [] for k in cases}
    with tempfile.TemporaryDirectory() as tmp:
        _sweep(os.path.join(tmp, "warm"), "--no-record")  # the caches, outside the timing
        for _ in range(rounds):
            for name, extra in cases.items():
                rates[name].append(_sweep(os.path.join(tmp, name), *extra))
    print(json.dumps({"benchmark": "sweep_throughput", "runs": RUNS, "cores": 1, "rounds": rounds,
                      "runs_per_second": {k: round(statistics.median(v), 2) for k, v in rates.items()},
                      "target_runs_per_second": TARGET,
                      "meets": {k: statistics.median(v) >= TARGET for k, v in rates.items()}}, indent=2))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
