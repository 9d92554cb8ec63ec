"""The simulator with every sensor in 20 ms frames, against CommonRoad's single-track model in plain Python: JSON.

``vilma sim`` and ``vilma up`` advance the simulator in 20 ms frames (two 10 ms physics steps, a reading or two
of each of the seven sensors at its default rate). The anchor is CommonRoad's single-track model
(``commonroad-vehicle-models``, the ``benchmark`` extra; BMW 320i parameters) stepped in plain Python at the same
10 ms step for the same sim time: with classical RK4, as vilma (the stricter anchor, the one the targets use), and
with scipy's ``odeint`` frame by frame, as the package's example integrates. All run interleaved in one process,
each repeat in turn; the figures are medians.

``all_sensors_read`` is the same with each frame's readings read (their stamps and values: views cut from the
sensors' blocks on access), what a consumer such as ``vilma sim`` pays on top.

Targets (issue 21): all sensors at least 3000x real time, and at least 4x the RK4 anchor.
"""

from __future__ import annotations

import json
import statistics
import time

import numpy as np

from vilma.core.messages import ActuatorCommand
from vilma.sensors import SensorSuite
from vilma.sim import SimConfig, Simulator

SIM_SECONDS, FRAME, STEP, REPEATS = 60.0, 0.02, 0.01, 7
TARGET_RTF, TARGET_RATIO = 3000.0, 4.0


def vilma(config: SimConfig, read: bool = False) -> float:
    """Wall seconds for :data:`SIM_SECONDS` of ``config`` in 20 ms frames; with ``read``, each frame's readings'
    stamps and values taken too (rows are cut from the sensors' blocks when read, as ``vilma sim`` reads them to
    publish them)."""
    sim = Simulator(config)
    sim.command(ActuatorCommand(steer=0.05, drive=1500.0))
    t0 = time.perf_counter()
    for _ in range(round(SIM_SECONDS / FRAME)):
        readings = sim.run_for(FRAME)
        if read:
            readings = [(r.stamp_ns, r.values) for r in readings.values()]
    return time.perf_counter() - t0


def commonroad_rk4() -> float:
    """Wall seconds for :data:`SIM_SECONDS` of CommonRoad ST with RK4 at :data:`STEP`, steering held, accelerating."""
    from vehiclemodels.parameters_vehicle2 import parameters_vehicle2
    from vehiclemodels.vehicle_dynamics_st import vehicle_dynamics_st as f

    p, u, h = parameters_vehicle2(), [0.0, 0.5], STEP
    x = [0.0, 0.0, 0.05, 5.0, 0.0, 0.0, 0.0]  # from 5 m/s: below 0.1 m/s the model switches to kinematic, stiffly
    t0 = time.perf_counter()
    for _ in range(round(SIM_SECONDS / h)):
        k1 = f(x, u, p)
        k2 = f([a + 0.5 * h * b for a, b in zip(x, k1, strict=True)], u, p)
        k3 = f([a + 0.5 * h * b for a, b in zip(x, k2, strict=True)], u, p)
        k4 = f([a + h * b for a, b in zip(x, k3, strict=True)], u, p)
        x = [a + h / 6.0 * (b + 2.0 * c + 2.0 * d + e) for a, b, c, d, e in zip(x, k1, k2, k3, k4, strict=True)]
    return time.perf_counter() - t0


def commonroad_odeint() -> float:
    """Wall seconds for :data:`SIM_SECONDS` of CommonRoad ST with scipy's ``odeint``, one call a 20 ms frame with
    outputs at :data:`STEP` (the package's example integration)."""
    from scipy.integrate import odeint
    from vehiclemodels.parameters_vehicle2 import parameters_vehicle2
    from vehiclemodels.vehicle_dynamics_st import vehicle_dynamics_st

    def rhs(x, t, u, p):
        return vehicle_dynamics_st(x, u, p)

    p, u, grid = parameters_vehicle2(), [0.0, 0.5], np.array([0.0, STEP, FRAME])
    x = np.array([0.0, 0.0, 0.05, 5.0, 0.0, 0.0, 0.0])
    t0 = time.perf_counter()
    for _ in range(round(SIM_SECONDS / FRAME)):
        x = odeint(rhs, x, grid, args=(u, p))[-1]
    return time.perf_counter() - t0


def main() -> None:
    runs = {"all_sensors": lambda: vilma(SimConfig()), "all_sensors_read": lambda: vilma(SimConfig(), read=True),
            "physics_only": lambda: vilma(SimConfig(sensors=SensorSuite.none())),
            "commonroad_st_rk4": commonroad_rk4, "commonroad_st_odeint": commonroad_odeint}
    for run in runs.values():  # compile / load the numba cache, import, outside the timing
        run()
    walls: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(REPEATS):
        for name, run in runs.items():
            walls[name].append(run())
    wall = {name: statistics.median(w) for name, w in walls.items()}
    rtf = {name: round(SIM_SECONDS / w, 1) for name, w in wall.items()}
    frames = SIM_SECONDS / FRAME
    ratio = round(wall["commonroad_st_rk4"] / wall["all_sensors"], 2)
    print(json.dumps({
        "benchmark": "sensors_speed", "frame_s": FRAME, "step_s": STEP, "sim_seconds": SIM_SECONDS, "repeats": REPEATS,
        "real_time_factor": rtf,
        "us_per_frame": {name: round(w / frames * 1e6, 2) for name, w in wall.items()},
        "all_sensors_vs_commonroad_st_rk4": ratio,
        "targets": {"all_sensors_real_time_factor": TARGET_RTF, "all_sensors_vs_commonroad_st_rk4": TARGET_RATIO},
        "met": {"real_time_factor": rtf["all_sensors"] >= TARGET_RTF, "vs_commonroad": ratio >= TARGET_RATIO},
    }, indent=2))


if __name__ == "__main__":
    main()
