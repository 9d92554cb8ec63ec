"""How long the benchmark's checks of a whole drive take, and how each CommonRoad scenario scores.

    python benchmarks/road_checks.py [FILE.xml ...]

Runs each CommonRoad file (default: the bundled ones) with its defaults, then times the checks of the whole
drive (:func:`vilma.world.benchmark.check_drive`: collision checker, road boundary, distances; best of 5)
against the issue's anchor of 0.2 s, and prints JSON, one entry per file, with the scorecard's road keys.
"""

from __future__ import annotations

import importlib.resources
import json
import sys
import time
from pathlib import Path

from vilma.scenario import load_scenario
from vilma.scenario.runner import run
from vilma.world.benchmark import EgoBox, check_drive

ANCHOR_S = 0.2
"""The issue's anchor for checking a whole drive [s]."""
KEYS = ("goal_reached", "collisions", "off_road", "min_distance_to_traffic_m", "min_time_to_collision_s",
        "time_to_goal_s", "realtime_factor", "incomplete_reason")


def measure(file: Path) -> dict:
    """Run ``file`` and time the checks of its drive."""
    result = run(load_scenario(file))
    c, car = result.log.column, result.scenario.sim.vehicle
    box = EgoBox(length=car.length, width=car.width, offset=car.body_offset)
    args = (c("t"), c("x"), c("y"), c("yaw"), c("vx"), c("vy"))
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        check_drive(result.scenario.road, box, *args)
        best = min(best, time.perf_counter() - t0)
    road = result.scenario.road
    return {"file": file.name, "obstacles": len(road.scenario.obstacles), "steps": len(road.samples(c("t"))),
            "check_s": best, "anchor_s": ANCHOR_S, **{k: result.metrics[k] for k in KEYS}}


def main(files: list[str]) -> None:
    paths = [Path(f) for f in files] or sorted(
        Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad")).glob("*.xml"))
    print(json.dumps([measure(p) for p in paths], indent=2))


if __name__ == "__main__":
    main(sys.argv[1:])
