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
- ``plain_mujoco_x_real_time_{20,100}ms``: the anchor (issue 21): plain MuJoCo (nothing of vilma in the timed
  loop) on the model file the 3D plant builds (:func:`~vilma.plant3d.car_model.car_xml`), the same sim seconds in
  the same frames: each frame sets the wheel torques and steering angles from Python, calls ``mj_step`` once per
  MuJoCo step and copies ``qpos``, ``qvel`` and ``sensordata``. ``ratio_to_plain_mujoco_{20,100}ms``: the 3D
  plant (every default sensor) over the anchor, the median of the ratios of runs made in turns (anchor, plant,
  anchor, plant ...: this machine's speed varies 2x). Target (issue 21): at least 0.9 at 20 ms.
  ``ratio_to_plain_mujoco_20ms_without_sensors``: the same with no sensor on the car (MuJoCo's stepping and vilma's
  actuators only), to show what the sensors cost. ``ratio_to_plain_mujoco_20ms_profiler_off``: the 3D plant over the
  anchor with MuJoCo's profiler off in the anchor too. The ``mujoco`` package's bindings turn MuJoCo's profiler on (a
  timer callback read 32 times a step, 7-8 % of a step here); vilma's stepping turns it off for its own steps
  (:mod:`vilma.plant3d.kernel`), so this ratio shows vilma's own cost beside MuJoCo's, with the profiler out of both.

Each figure is the median of ``REPEAT`` runs (``PAIRS`` pairs against the anchor). Usage:
``python benchmarks/plant3d.py``.
"""

from __future__ import annotations

import dataclasses
import json
import statistics
import sys
import time

from vilma.app.batch import find_scenario
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.plant3d import kernel
from vilma.plant3d.camera import stereo_pair
from vilma.plant3d.car_model import car_xml
from vilma.scenario import load_scenario
from vilma.scenario.runner import run
from vilma.sensors import SensorSuite
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import VX

REPEAT = 3
PAIRS = 5
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


def _plain_mujoco(config: SimConfig, seconds: float, chunk: float, profiler: bool = True) -> float:
    """Sim seconds per wall second of plain MuJoCo on the 3D plant's model of ``config`` (no cameras), a gentle
    weave at about 8 m/s as :func:`_plant`'s, in frames of ``chunk`` [s]; ``profiler``: MuJoCo's profiler as the
    bindings leave it (on), else off."""
    import mujoco  # here: vilma.plant3d, imported first, picks MuJoCo's headless OpenGL for the cameras

    imu = config.sensors.imu.offset if config.sensors.imu is not None else (0.0, 0.0, 0.0)
    m = mujoco.MjModel.from_xml_string(car_xml(config.vehicle, config.world, "", imu))
    d = mujoco.MjData(m)
    steps = round(chunk / m.opt.timestep)
    per_accel = config.vehicle.mass * config.vehicle.wheel_radius / 4  # wheel torque per m/s^2 [N m s^2/m]
    timer = int(kernel.MJCB_TIME[0])
    if not profiler:
        kernel.MJCB_TIME[0] = 0
    try:
        t0 = time.perf_counter()
        for i in range(round(seconds / chunk)):
            steer = 0.05 if (i * chunk // 5) % 2 else -0.05
            torque = per_accel * 0.5 * (8.0 - d.qvel[0])
            d.ctrl[:] = (torque, torque, torque, torque, steer, steer)
            for _ in range(steps):
                mujoco.mj_step(m, d)
            d.qpos.copy(), d.qvel.copy(), d.sensordata.copy()
        return seconds / (time.perf_counter() - t0)
    finally:
        kernel.MJCB_TIME[0] = timer


def _against_plain(config: SimConfig, chunk: float, profiler: bool = True) -> tuple[float, float, float]:
    """Medians of the plain MuJoCo anchor's (``profiler``: see :func:`_plain_mujoco`) and the 3D plant's real-time
    factors in ``chunk`` [s] frames, and of their ratios, the two run in turns."""
    pairs = [(_plain_mujoco(config, SECONDS, chunk, profiler), _plant(config, SECONDS, chunk)) for _ in range(PAIRS)]
    plain, plant = zip(*pairs, strict=True)
    return (round(statistics.median(plain), 1), round(statistics.median(plant), 1),
            round(statistics.median(b / a for a, b in pairs), 2))


def _median(fn) -> float:
    return round(statistics.median(fn() for _ in range(REPEAT)), 1)


def main() -> None:
    plant = SimConfig(model="mujoco")
    out: dict = {"benchmark": "plant3d", "sim_seconds": SECONDS}
    out["plant_x_real_time_chunks_1000ms"] = _median(lambda: _plant(plant, SECONDS, 1.0))
    for chunk in (0.1, 0.02):
        ms = round(chunk * 1000)
        out[f"plain_mujoco_x_real_time_{ms}ms"], out[f"plant_x_real_time_chunks_{ms}ms"], \
            out[f"ratio_to_plain_mujoco_{ms}ms"] = _against_plain(plant, chunk)
    out["ratio_to_plain_mujoco_20ms_profiler_off"] = _against_plain(plant, 0.02, profiler=False)[2]
    bare = SimConfig(model="mujoco", sensors=SensorSuite(**{f.name: None for f in dataclasses.fields(SensorSuite)}))
    out["ratio_to_plain_mujoco_20ms_without_sensors"] = _against_plain(bare, 0.02)[2]
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
