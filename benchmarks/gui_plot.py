"""GUI plot refresh with one hour of 100 Hz history on every curve; prints JSON (targets: 16 ms, 500 MB).

Offscreen Qt. Fills the bridge's ring buffers with 360 000 samples per
series (a car driving a looping course), opens the plot window at
1100 x 700 and times a full refresh: every curve handed its whole history,
then the window painted. Two views: the whole hour (worst case: every
sample in view, downsampled to the pixels) and the last minute (clipped).
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import time

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import numpy as np
from PySide6.QtWidgets import QApplication

from vilma.bus.local import LocalBus
from vilma.gui.bridge import BusBridge
from vilma.gui.plots import PlotWindow
from vilma.gui.waypoints import WaypointModel
from vilma.trajectory import Trajectory

N = 360_000
"""One hour at 100 Hz."""
RATE = 100.0
REPEATS = 30


def rss_mb() -> float:
    """Resident memory now [MB]."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def fill(bridge: BusBridge) -> None:
    """An hour of a car lapping a 100 m circle at 5 m/s with noisy speed, steering and forces."""
    rng = np.random.default_rng(0)
    t = np.arange(N) / RATE
    a = 5.0 * t / 100.0
    h = bridge.history
    h["path"].extend(np.column_stack([t, 100 * np.cos(a), 100 * np.sin(a)]))
    h["speed"].extend(np.column_stack([t, 5 + 0.1 * rng.standard_normal(N)]))
    h["actuators"].extend(np.column_stack([t, 0.05 + 0.01 * rng.standard_normal(N), 400 + 50 * rng.standard_normal(N),
                                           np.zeros(N)]))
    h["driver"].extend(np.column_stack([t, np.full(N, 5.0), 5 + 0.1 * rng.standard_normal(N),
                                        0.02 * rng.standard_normal(N), np.arange(N) % 700]))


def time_refresh(app: QApplication, plots: PlotWindow) -> list[float]:
    """Wall times of REPEATS full refreshes (data handed over, the window painted) [ms]."""
    out = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        plots.refresh(force=True)
        app.processEvents()  # the scene updates and the window paints once
        out.append((time.perf_counter() - t0) * 1e3)
    return out


def main() -> None:
    app = QApplication.instance() or QApplication([])
    rss0 = rss_mb()
    bridge = BusBridge(LocalBus(), history_seconds=N / RATE, history_rate=RATE)
    fill(bridge)
    waypoints = WaypointModel()
    a = np.linspace(0, 2 * np.pi, 700)
    waypoints.set_trajectory(Trajectory(np.column_stack([100 * np.cos(a), 100 * np.sin(a)])))
    plots = PlotWindow(bridge, waypoints)
    plots.resize(1100, 700)
    plots.show()
    app.processEvents()
    plots.timer.stop()  # only the timed refreshes draw
    whole = time_refresh(app, plots)
    plots.speed_plot.setXRange(N / RATE - 60, N / RATE, padding=0)  # the last minute (time plots are x-linked)
    app.processEvents()
    minute = time_refresh(app, plots)
    print(json.dumps({
        "benchmark": "gui_plot",
        "points_per_curve": len(bridge.history["speed"]),
        "curves": 8,
        "history_seconds": N / RATE,
        "window_px": [plots.width(), plots.height()],
        "refresh_ms_median_whole_hour": round(statistics.median(whole), 2),
        "refresh_ms_max_whole_hour": round(max(whole), 2),
        "refresh_ms_median_last_minute": round(statistics.median(minute), 2),
        "target_ms": 16.0,
        "history_mb": round(sum(h.nbytes for h in bridge.history.values()) / 2**20, 1),
        "rss_mb_before_gui": round(rss0, 1),
        "rss_mb": round(rss_mb(), 1),
        "rss_mb_peak": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
        "target_rss_mb": 500.0,
    }))
    plots.close()
    bridge.close()


if __name__ == "__main__":
    main()
