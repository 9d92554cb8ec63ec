"""Simulator speed and memory: prints JSON.

- ``real_time_factor``: simulated seconds per wall second of the dynamic
  single-track model with every sensor at its default rate, one process, for
  several sizes of ``run_for`` chunk (a controller calls every 20-50 ms; a
  headless open-loop run can take whole seconds). Median of 5 runs of 60 s.
- ``physics_only``: the same without sensors.
- ``one_hour_drive``: peak resident memory of a process that simulates one
  hour with all sensors (readings streamed, not kept), and the Python heap peak.

Targets (issue 2): >= 2000x real time; < 200 MB for the one-hour drive.
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import time

from vilma.core.messages import ActuatorCommand
from vilma.sensors import SensorSuite
from vilma.sim import SimConfig, Simulator

SIM_SECONDS = 60.0
REPEATS = 5


def _rtf(config: SimConfig, chunk: float) -> float:
    rates = []
    for _ in range(REPEATS):
        sim = Simulator(config)
        sim.command(ActuatorCommand(steer=0.05, drive=1500.0))
        n = round(SIM_SECONDS / chunk)
        t0 = time.perf_counter()
        for _ in range(n):
            sim.run_for(chunk)
        rates.append(SIM_SECONDS / (time.perf_counter() - t0))
    return round(statistics.median(rates), 1)


def _one_hour() -> dict:
    import tracemalloc

    tracemalloc.start()
    sim = Simulator()
    sim.command(ActuatorCommand(steer=0.02, drive=1500.0))
    readings = 0
    for _ in range(3600):
        readings += sum(len(r) for r in sim.run_for(1.0).values())
    _, heap_peak = tracemalloc.get_traced_memory()
    return {"readings": readings, "python_heap_peak_mb": round(heap_peak / 2**20, 1),
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)}


def main() -> None:
    if sys.argv[1:] == ["--one-hour"]:
        print(json.dumps(_one_hour()))
        return
    Simulator().run_for(0.1)  # compile / load the numba cache outside the timing
    out = {
        "benchmark": "simulator",
        "model": "single_track",
        "step_s": SimConfig().step,
        "sensors_hz": {"pose": 50, "velocity": 50, "gps": 10, "imu": 100, "wheel_speed": 50, "odometry": 50,
                       "actuators": 50},
        "sim_seconds_per_run": SIM_SECONDS,
        "real_time_factor": {f"chunk_{c:g}s": _rtf(SimConfig(), c) for c in (0.02, 0.25, 1.0, 10.0)},
        "physics_only": {f"chunk_{c:g}s": _rtf(SimConfig(sensors=SensorSuite.none()), c) for c in (0.02, 10.0)},
        "cpu_count_used": 1,
    }
    env = dict(os.environ, OMP_NUM_THREADS="1")
    hour = subprocess.run([sys.executable, __file__, "--one-hour"], capture_output=True, text=True, env=env,
                          check=True)
    out["one_hour_drive"] = json.loads(hour.stdout)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
