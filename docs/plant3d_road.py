"""Make docs/plant3d-road.png: the front camera of the 3D plant on CommonRoad's tutorial road (its lanelets and lane
markings), and a camera on the roof looking back at the recorded car changing into the lane behind, the car
coasting from the planning problem's initial state.

Usage: ``python docs/plant3d_road.py`` (writes the PNG beside this file).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from vilma.plant3d.camera import CameraParams  # noqa: E402
from vilma.scenario import load_scenario  # noqa: E402
from vilma.sim import Simulator  # noqa: E402
from vilma.vehicle.state import VehicleState  # noqa: E402

SHOTS = ((0.5, "front"), (1.5, "back"))
"""Sim time [s] and camera of each frame."""


def main() -> None:
    s = load_scenario("commonroad_tutorial", overrides={"plant": "mujoco"})
    task = s.road
    start = VehicleState(x=task.x, y=task.y, yaw=task.yaw, vx=task.speed)
    cameras = (CameraParams(width=800, height=450, pitch=0.05, rate_hz=2.0),
               CameraParams(name="back", position=(-1.0, 0.0, 1.0), yaw=np.pi, pitch=0.1, width=800, height=450,
                            rate_hz=2.0))
    sim = Simulator(dataclasses.replace(s.sim, cameras=cameras, initial=start))
    frames = []
    for t, name in SHOTS:
        sim.run_for(t - sim.time_ns / 1e9)
        image = dict(sim.take_captures())[f"camera/{name}"]
        frames.append(np.frombuffer(image.data, np.uint8).reshape(image.height, image.width, 3))
    sim.close()
    fig, ax = plt.subplots(1, len(frames), figsize=(16, 4.8))
    for a, (t, name), frame in zip(ax, SHOTS, frames, strict=True):
        a.imshow(frame)
        a.set_title(f"camera/{name} at {t:g} s: ZAM_Tutorial-1_1_T-1, plant mujoco")
        a.set_axis_off()
    fig.tight_layout()
    fig.savefig(Path(__file__).with_name("plant3d-road.png"), dpi=80)


if __name__ == "__main__":
    main()
