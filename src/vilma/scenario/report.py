"""PNG plots of a run, as the paper's figures: the path (Figure 12), speed (Figure 11), errors and effort."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from vilma.core.files import atomic_path

if TYPE_CHECKING:
    from vilma.scenario.runner import RunResult

MAX_POINTS = 20_000
"""Points drawn per line at most (every k-th sample of longer runs: a PNG cannot show more)."""


def plot_run(result: RunResult, out_dir: Path, speed_log: tuple[np.ndarray, np.ndarray] | None = None) -> None:
    """Write the plots (:data:`vilma.scenario.folder.PLOTS`) into ``out_dir``; ``speed_log`` (times [s], speeds
    [m/s]) is overlaid on the speed."""
    log, name = result.log, result.scenario.name
    every = max(1, -(-len(log) // MAX_POINTS))

    def col(c: str) -> np.ndarray:
        return log.column(c)[::every]

    t = col("t") - result.t_start
    x, y = col("x"), col("y")

    fig, ax = plt.subplots(figsize=(7, 6))
    if result.path is not None:
        ax.plot(result.path.xy[:, 0], result.path.xy[:, 1], "r-", lw=1.5, label="trajectory")
    ax.plot(x, y, "b-", lw=1.0, label="car position")
    ax.set(xlabel="x [m] (east)", ylabel="y [m] (north)", title=f"{name}: path", aspect="equal")
    ax.legend()
    _save(fig, out_dir / "path.png")

    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(t, np.hypot(col("vx"), col("vy")), "b-", label="vilma speed")
    ax.plot(t, col("target_speed"), "k--", lw=1.0, label="target")
    if speed_log is not None:
        ax.plot(speed_log[0], speed_log[1], "r.-", ms=3, lw=0.8, label="original (log)")
    ax.set(xlabel="time since start [s]", ylabel="speed [m/s]", title=f"{name}: speed")
    ax.grid(alpha=0.3)
    ax.legend()
    _save(fig, out_dir / "speed.png")

    fig, ax = plt.subplots(figsize=(8, 4))
    if result.path is not None:
        proj = result.path.project_track(np.column_stack([x, y]))
        ax.plot(proj[:, 0], proj[:, 1], "b-")
        ax.set(xlabel="distance along the path [m]")
    else:
        ax.text(0.5, 0.5, "no path in this task", ha="center", transform=ax.transAxes)
    ax.set(ylabel="cross-track error [m] (left +)", title=f"{name}: cross-track error")
    ax.grid(alpha=0.3)
    _save(fig, out_dir / "cross_track.png")

    fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    a1.plot(t, np.degrees(col("steer")), "b-", label="applied")
    a1.plot(t, np.degrees(col("cmd_steer")), "k--", lw=0.8, label="commanded")
    a1.set(ylabel="steering [deg]", title=f"{name}: steering, drive command and forces")
    a1.legend()
    d = result.scenario.driver
    unit = "power (original units)" if d.speed_controller == "vilma_pid" else "force [N]"
    a2.plot(t, col("cmd_drive"), "m-", label=f"{d.speed_controller} command")
    a2.set(ylabel=f"drive: {unit}")
    a2.legend()
    speed = np.hypot(col("vx"), col("vy"))
    a3.plot(t, col("drive_force"), "g-", label="drive force")
    a3.plot(t, -col("brake_force"), "r-", label="brake force (negative)")
    a3.set(xlabel="time since start [s]", ylabel="applied force [N]")
    a3.legend(loc="upper left")
    kw = a3.twinx()
    kw.plot(t, col("drive_force") * speed / 1000.0, "k:", label="drive power")
    kw.set(ylabel="drive power [kW]")
    kw.legend(loc="upper right")
    for a in (a1, a2, a3):
        a.grid(alpha=0.3)
    _save(fig, out_dir / "effort.png")


def _save(fig, path: Path) -> None:
    fig.tight_layout()
    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, format="png")
    finally:
        plt.close(fig)
