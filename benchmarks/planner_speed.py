"""Local motion planner speed, one core: prints JSON.

A planning cycle (:func:`vilma.planning.plan`) on a curved three-lane road with 20 predicted objects moving
along it 10 to 80 m ahead of the car (one lane oncoming) over the 3 s horizon, every candidate checked (a few
hundred), replanned every period from the last plan's state for 60 s of driving after a warm-up.

Target (issue 20): under 10 ms mean and 25 ms max per cycle on one core. Anchor: CommonRoad's reactive planner
takes 22-99 ms per cycle on real scenarios; vilma must be at least 5x faster (``speedup_vs_22ms``: how many
times the mean cycle fits in 22 ms).
"""

from __future__ import annotations

import json
import math
import os
import statistics
import time

import numpy as np

from vilma.planning import FrenetFrame, FrenetState, PlannerParams, plan
from vilma.trajectory import Trajectory

OBJECTS = 20
SECONDS = 60.0
WARMUP = 20
LANE = 3.5
NEAR, SPAN = 10.0, 70.0


def _road() -> FrenetFrame:
    """A 1.2 km road of alternating 150 m radius curves."""
    s = np.linspace(0.0, 1200.0, 1201)
    heading = 0.6 * np.sin(s / 150.0)
    ds = np.diff(s, prepend=0.0)
    return FrenetFrame(Trajectory.from_points(np.column_stack([np.cumsum(ds * np.cos(heading)),
                                                               np.cumsum(ds * np.sin(heading))])))


def _traffic(rng) -> np.ndarray:
    """Objects (n, 4): arc length [m], lane offset [m], speed along the road [m/s] (negative: oncoming), length."""
    s = rng.uniform(NEAR, NEAR + SPAN, OBJECTS)
    lane = rng.choice([-LANE, 0.0, LANE], OBJECTS)
    speed = np.where(lane < 0, -rng.uniform(8.0, 12.0, OBJECTS), rng.uniform(6.0, 12.0, OBJECTS))
    return np.column_stack([s, lane, speed, rng.uniform(4.0, 12.0, OBJECTS)])


def _predict(frame: FrenetFrame, traffic: np.ndarray, now: float, ego_s: float, t: np.ndarray) -> np.ndarray:
    """Boxes (n, n_t, 5) of the objects at times ``t`` [s] from ``now``, each keeping its lane and speed; an object
    that has left the stretch ``NEAR .. NEAR + SPAN`` ahead of the car (at ``ego_s`` [m]) comes back at its other
    end, so that the traffic stays around the car."""
    start = ego_s + NEAR + np.mod(traffic[:, :1] + traffic[:, 2:3] * now - ego_s - NEAR, SPAN)
    s = start + traffic[:, 2:3] * t
    x, y = frame.to_cartesian(s, np.broadcast_to(traffic[:, 1:2], s.shape))
    yaw = np.vectorize(lambda v: frame.pose(v)[2])(s) + np.where(traffic[:, 2:3] < 0, math.pi, 0.0)
    return np.stack([x, y, yaw, np.broadcast_to(traffic[:, 3:4], s.shape), np.full(s.shape, 1.9)], axis=-1)


def main() -> None:
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    frame, params = _road(), PlannerParams()
    traffic = _traffic(np.random.default_rng(0))
    state = FrenetState(0.0, params.target_speed, 0.0, 0.0)
    cycles = round(SECONDS / params.replan_period)
    times, modes, candidates, status = [], {}, [], np.zeros(3, dtype=int)
    for k in range(WARMUP + cycles):
        objects = _predict(frame, traffic, k * params.replan_period, state.s, params.times)  # the perception's part
        t0 = time.perf_counter()
        p = plan(state, frame, objects, params)
        elapsed = time.perf_counter() - t0
        if k >= WARMUP:
            times.append(elapsed * 1e3)
            modes[p.mode] = modes.get(p.mode, 0) + 1
            candidates.append(len(p.candidates.status))
            status += np.bincount(p.candidates.status, minlength=3)
        state = p.state_at(params.replan_period)
    mean = statistics.fmean(times)
    print(json.dumps({
        "benchmark": "planner_speed", "objects": OBJECTS, "horizon_s": params.horizon, "dt_s": params.dt,
        "cycles": cycles, "candidates_per_cycle": {"min": min(candidates), "max": max(candidates)},
        "candidates_share": {name: round(float(n / status.sum()), 3)
                             for name, n in zip(("feasible", "infeasible", "colliding"), status, strict=True)},
        "modes": modes, "mean_ms": round(mean, 3), "p50_ms": round(statistics.median(times), 3),
        "p99_ms": round(statistics.quantiles(times, n=100)[98], 3), "max_ms": round(max(times), 3),
        "target_mean_ms": 10.0, "target_max_ms": 25.0,
        "meets_targets": mean < 10.0 and max(times) < 25.0,
        "commonroad_reactive_ms": [22, 99], "speedup_vs_22ms": round(22.0 / mean, 1),
    }, indent=2))


if __name__ == "__main__":
    main()
