"""Speed of the 3D plant (MuJoCo): prints JSON.

- ``plant``: the simulator alone on the 3D plant, a new command every chunk (a gentle weave at about 8 m/s),
  every sensor at its default rate, advanced in chunks of 1 s, 100 ms and 20 ms (20 ms is how ``vilma sim``
  serves frames on the bus; below 100 ms the per-call cost of the sensors' batches, not MuJoCo, dominates, as
  ``benchmarks/sim_speed.py`` shows for the single-track plant). Target (issue 8): at least 50x real time
  without cameras.
- ``plant_stereo``: the same in 100 ms chunks with the front stereo pair, RGB 640x480 at 10 Hz (rendered on
  the CPU through EGL). Target: at least real time.
- ``closed_loop``: ``vilma run paper_fig12_path --plant mujoco`` (the driver in Python at 100 Hz), and the
  same scenario on the single-track plant in the same Python loop, for scale.

Each figure is the median of ``REPEAT`` runs. Usage: ``python benchmarks/plant3d.py``.
"""

from __future__ import annotations

import json
import statistics
import sys
import time

from vilma.app.batch import find_scenario
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.plant3d.camera import stereo_pair
from vilma.scenario import load_scenario
from vilma.scenario.runner import run
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import VX

REPEAT = 3
SECONDS = 60.0


def _plant(config: SimConfig, seconds: float, chunk: float) -> float:
    """Sim seconds per wall second, advancing ``chunk`` [s] at a time with a new command each time."""
    sim = Simulator(config)
    t0 = time.perf_counter()
    for i in range(round(seconds / chunk)):
        steer = 0.05 if (i * chunk // 5) % 2 else -0.05
        sim.command(ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=0.5 * (8.0 - sim.plant[VX]), steer=steer))
        sim.run_for(chunk)
        sim.take_captures()
    wall = time.perf_counter() - t0
    sim.close()
    return seconds / wall


def _median(fn) -> float:
    return round(statistics.median(fn() for _ in range(REPEAT)), 1)


def main() -> None:
    plant = SimConfig(model="mujoco")
    out: dict = {"benchmark": "plant3d", "sim_seconds": SECONDS}
    for chunk in (1.0, 0.1, 0.02):
        out[f"plant_x_real_time_chunks_{round(chunk * 1000)}ms"] = _median(lambda c=chunk: _plant(plant, SECONDS, c))
    stereo = SimConfig(model="mujoco", cameras=stereo_pair(width=640, height=480, rate_hz=10.0))
    out["plant_stereo_640x480_10hz_x_real_time"] = _median(lambda: _plant(stereo, 10.0, 0.1))
    scenario = find_scenario("paper_fig12_path")
    for label, plant_name in (("closed_loop_3d_x_real_time", "mujoco"),
                              ("closed_loop_single_track_python_x_real_time", "single_track")):
        sc = load_scenario(scenario, {"plant": plant_name})
        out[label] = _median(lambda sc=sc: run(sc, compiled=False).metrics["realtime_factor"])
    json.dump(out, sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
