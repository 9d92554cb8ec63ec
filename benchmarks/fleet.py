"""Many cars in one process (:func:`vilma.scenario.fleet.run_fleet`): prints JSON.

- ``per_car_second_ms``: wall time per car-second of ``run_fleet`` on N cars of ``course_30kmh_stanley`` (a 34 s
  drive, seeds 0..N-1), N = 1, 10, 100, 1000, in this process with warm caches; medians of interleaved rounds.
  The anchor: the same cars driven one by one with :func:`vilma.scenario.runner.run`, N = 10, measured in the same
  rounds. Target (issue 21): at N = 1000 at most 1/10 of N = 1's.
- ``plant_floor_ms``: the plant alone (RK4 at 10 ms, compiled, nothing recorded) per car-second: what any loop that
  drives these cars bit-identically pays at least; ``floor_ratio_to_n1``: that, shared by the threads of
  :data:`~vilma.scenario.fleet.THREADS` (one a core), over N = 1's cost: the least ratio such a loop could reach on
  this machine, with no driver, sensors, log or scorecard at all.
- ``memory``: peak resident memory of a process that drives 1000 cars x 60 s (``paper_fig11_speed_10`` at 60 s)
  with the default logs, with its files written by ``vilma run --cars 1000``. Target (issue 21): < 2 GB.
"""

from __future__ import annotations

import dataclasses
import json
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from vilma.scenario import fleet, load_scenario
from vilma.scenario.fleet import THREADS, run_fleet
from vilma.scenario.runner import run
from vilma.sim import Simulator
from vilma.vehicle.integrate import advance, empty_records

ROUNDS = 3
SIZES = (1, 10, 100, 1000)


def _cars(n: int) -> list:
    s = load_scenario("course_30kmh_stanley")
    return [dataclasses.replace(s, sim=dataclasses.replace(s.sim, seed=k)) for k in range(n)]


def _per_car_second(drive, cars) -> float:
    t0 = time.perf_counter()
    results = drive(cars)
    return 1e3 * (time.perf_counter() - t0) / sum(r.metrics["sim_time_s"] for r in results)


def _plant_floor() -> float:
    """ms of wall time per car-second of the plant alone (two RK4 steps a 20 ms period)."""
    p, n = Simulator().kernel_start(2), 6000  # the plant as compiled code gets it
    out = empty_records(n)
    cmd, never = np.array([0.05, 0.3, 0.0, np.inf]), np.array([1 << 40], dtype=np.int64)
    times = []
    for _ in range(7):
        z = p.z.copy()
        z[3] = 8.0
        t0 = time.perf_counter()
        advance(p.model, p.integrator, z, 0, cmd, p.consts, p.step, n, 0, never, *out)
        times.append(time.perf_counter() - t0)
    return 1e3 * min(times) / (n * p.step)


def _memory() -> dict:
    with tempfile.TemporaryDirectory() as out:
        code = ("import resource, sys; from vilma.app.cli import main; rc = main(['run', 'paper_fig11_speed_10', "
                "'--set', 'duration=60', '--set', 'expect={}', '--cars', '1000', '--out', sys.argv[1], '-q']); "
                "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)")
        t0 = time.perf_counter()
        done = subprocess.run([sys.executable, "-c", code, out], capture_output=True, text=True, check=True)
        return {"cars": 1000, "sim_seconds_each": 60, "wall_s": round(time.perf_counter() - t0, 1),
                "peak_rss_mb": round(float(done.stdout.split()[-1])), "target_mb": 2048}


def main() -> None:
    run_fleet(_cars(2))  # load the compiled code outside the timing
    fleets = {n: [] for n in SIZES}
    alone, one_thread = [], []
    for _ in range(ROUNDS):
        alone.append(_per_car_second(lambda cars: [run(s) for s in cars], _cars(10)))
        for n in SIZES:
            fleets[n].append(_per_car_second(run_fleet, _cars(n)))
        fleet.THREADS = 1  # read by each wave
        one_thread.append(_per_car_second(run_fleet, _cars(SIZES[-1])))
        fleet.THREADS = THREADS
    per = {n: round(statistics.median(v), 4) for n, v in fleets.items()}
    floor = _plant_floor()
    print(json.dumps({
        "benchmark": "fleet",
        "scenario": "course_30kmh_stanley",
        "per_car_second_ms": per,
        "anchor_run_one_by_one_ms": round(statistics.median(alone), 4),
        "ratio_n1000_to_n1": round(per[1000] / per[1], 3),
        "ratio_n1000_to_n1_one_thread": round(statistics.median(one_thread) / per[1], 3),
        "target_ratio": 0.1,
        "plant_floor_ms": round(floor, 4),
        "threads": THREADS,
        "floor_ratio_to_n1": round(floor / THREADS / per[1], 3),
        "memory": _memory(),
    }, indent=2))


if __name__ == "__main__":
    main()
