"""Make docs/plant3d-view.png: what the front-left camera (RGB and depth) and the laser see on the 3D plant.

Usage: ``python docs/plant3d_view.py`` (writes the PNG beside this file).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from vilma.plant3d.camera import stereo_pair  # noqa: E402
from vilma.plant3d.laser import LaserParams  # noqa: E402
from vilma.plant3d.world import Box, Bump, Cone, Ramp, World  # noqa: E402
from vilma.sim import SimConfig, Simulator  # noqa: E402

WORLD = World(boxes=(Box(pos=(22.0, -3.0, 0.75), size=(1.0, 1.0, 0.75), rgba=(0.8, 0.1, 0.1, 1.0)),),
              cones=tuple(Cone(pos=(6.0 + 4.0 * k, side)) for k in range(6) for side in (-2.5, 2.5)),
              ramps=(Ramp(start=(30.0, 1.0), length=8.0, height=0.6, top=4.0, width=4.0),),
              bumps=(Bump(pos=(12.0, 0.0), width=5.0),))


def main() -> None:
    sim = Simulator(SimConfig(model="mujoco", world=WORLD, laser=LaserParams(),
                              cameras=stereo_pair(width=640, height=480, rate_hz=10.0, depth=True)))
    sim.run_for(0.1)
    shots = dict(sim.take_captures())
    sim.close()
    rgb, depth, scan = shots["camera/front_left"], shots["camera/front_left/depth"], shots["laser"]
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2), gridspec_kw={"width_ratios": [4, 4, 3]})
    ax[0].imshow(np.frombuffer(rgb.data, np.uint8).reshape(rgb.height, rgb.width, 3))
    ax[0].set_title("camera/front_left (RGB 640x480)")
    d = np.frombuffer(depth.data, "<f4").reshape(depth.height, depth.width)
    shown = ax[1].imshow(np.where(np.isfinite(d), d, np.nan), cmap="viridis_r", vmax=40.0)
    fig.colorbar(shown, ax=ax[1], label="depth [m]")
    ax[1].set_title("camera/front_left/depth (sky: no return)")
    for a in ax[:2]:
        a.set_axis_off()
    p = np.frombuffer(scan.points, "<f4").reshape(-1, 3)
    ax[2].scatter(p[:, 1], p[:, 0], s=4)
    ax[2].plot(0, 0, "k^")
    ax[2].set(xlabel="y (left) [m]", ylabel="x (ahead) [m]", title="laser (181 rays, 30 m)", aspect="equal")
    ax[2].invert_xaxis()
    fig.tight_layout()
    fig.savefig(Path(__file__).with_name("plant3d-view.png"), dpi=80)


if __name__ == "__main__":
    main()
