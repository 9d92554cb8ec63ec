"""Speed of the 3D plant (MuJoCo): prints JSON.

- ``plant``: the simulator alone on the 3D plant, as ``vilma sim`` runs it: 20 ms frames, a command a
  frame, every sensor at its default rate, 60 s of sim time on the Fig. 12 course's speeds. Target
  (issue 8): at least 50x real time without cameras.
- ``plant_stereo``: the same with the front stereo pair, RGB 640x480 at 10 Hz (rendered on the CPU
  through EGL). Target: at least real time.
- ``closed_loop``: ``vilma run paper_fig12_path --plant mujoco`` (the driver in Python at 100 Hz), and the
  same scenario on the single-track plant in the same Python loop, for scale.

Each figure is the median of ``REPEAT`` runs. Usage: ``python benchmarks/plant3d.py``.
"""

from __future__ import annotations

import json
import statistics
import sys
import time

from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.scenario import load_scenario
from vilma.scenario.batch import find_scenario
from vilma.scenario.runner import run
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import VX

REPEAT = 3
SECONDS = 60.0


def _plant(config: SimConfig, seconds: float) -> float:
    """Sim seconds per wall second of 20 ms frames, each with a new command (a gentle weave at ~8 m/s)."""
    sim = Simulator(config)
    frames = round(seconds / 0.02)
    t0 = time.perf_counter()
    for i in range(frames):
        steer = 0.05 if (i // 250) % 2 else -0.05
        sim.command(ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=0.5 * (8.0 - sim.plant[VX]), steer=steer))
        sim.advance(2)
        sim.take_captures()
    return seconds / (time.perf_counter() - t0)


def _median(fn) -> float:
    return round(statistics.median(fn() for _ in range(REPEAT)), 1)


def main() -> None:
    plant = SimConfig(model="mujoco")
    out: dict = {"benchmark": "plant3d", "sim_seconds": SECONDS,
                 "plant_x_real_time": _median(lambda: _plant(plant, SECONDS))}
    try:
        from vilma.plant3d.camera import stereo_pair
    except ImportError:
        out["plant_stereo_x_real_time"] = None
    else:
        stereo = SimConfig(model="mujoco", cameras=stereo_pair(width=640, height=480, rate_hz=10.0))
        out["plant_stereo_x_real_time"] = _median(lambda: _plant(stereo, 10.0))
    scenario = find_scenario("paper_fig12_path")
    for label, plant_name in (("closed_loop_3d_x_real_time", "mujoco"),
                              ("closed_loop_single_track_python_x_real_time", "single_track")):
        sc = load_scenario(scenario, {"plant": plant_name})
        out[label] = _median(lambda sc=sc: run(sc, compiled=False).metrics["realtime_factor"])
    json.dump(out, sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
