"""Trajectory smoothing speed: prints JSON.

- ``banded``: :func:`vilma.trajectory.smooth.smooth_banded` (the direct solution) on a noisy 100 000-point
  path, median of 7 runs. Target (issue 3): under 0.5 s.
- ``iterative``: the paper's Algorithm 1 (:func:`smooth_iterative`, compiled) on the same path, one run,
  with the largest distance between the two results (issue 3: within 1e-4 m).
- ``recorded_curve``: both on the original's curved log after Increase Point Count (713 points).
"""

from __future__ import annotations

import json
import statistics
import time
from pathlib import Path

import numpy as np

from vilma.trajectory import increase_point_count, load_trajectory
from vilma.trajectory.smooth import smooth_banded, smooth_iterative

N = 100_000
REPEATS = 7
CURVED = Path(__file__).resolve().parents[2] / "shared" / "reference" / "original-logs" / "PositionLog_curved.txt"


def _noisy_path(n: int) -> np.ndarray:
    rng = np.random.default_rng(0)
    s = np.linspace(0.0, n * 0.5, n)  # a point every 0.5 m: a 50 km drive
    return np.column_stack([s, 20.0 * np.sin(s / 200.0)]) + rng.normal(0.0, 0.3, (n, 2))


def _time(f, *args) -> tuple[float, np.ndarray]:
    t0 = time.perf_counter()
    out = f(*args)
    return time.perf_counter() - t0, out


def _compare(xy: np.ndarray, repeats: int) -> dict:
    smooth_banded(xy[:10])
    smooth_iterative(xy[:10])  # compile / load the numba cache outside the timing
    banded_s = statistics.median(_time(smooth_banded, xy)[0] for _ in range(repeats))
    iterative_s, iterative = _time(smooth_iterative, xy)
    gap = float(np.max(np.hypot(*(smooth_banded(xy) - iterative).T)))
    return {"points": len(xy), "banded_s": round(banded_s, 5), "iterative_s": round(iterative_s, 4),
            "max_difference_m": gap}


def main() -> None:
    out = {"benchmark": "smoothing", "alpha": 0.5, "beta": 0.1, "tolerance": 1e-6,
           "noisy_100k": _compare(_noisy_path(N), REPEATS)}
    if CURVED.exists():
        out["recorded_curve"] = _compare(increase_point_count(load_trajectory(CURVED)).xy, REPEATS)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
