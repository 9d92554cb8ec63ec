"""vilma's planner against CommonRoad's own ``commonroad-reactive-planner`` on the same CommonRoad scenarios.

    python benchmarks/planner_vs_reactive.py [--scenarios DIR]

For every CommonRoad file in ``DIR`` (default: ``../shared/commonroad`` beside the repository) and every bundled
one (a file already run by content is skipped), both sides (vilma with truth and with laser perception) drive the
file's planning problem and are scored alike
(:mod:`vilma.world.benchmark`): goal reached, collisions, off-road, time to goal [s], planning time per cycle [ms].
The reactive planner is ``benchmarks/anchors/reactive_planner.py`` (the ``benchmark`` extra), a subprocess per file
so that a crash of its C++ parts is a row too. Prints JSON, one entry per file, and a markdown table to stderr.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib.resources
import importlib.util
import json
import subprocess
import sys
from pathlib import Path

from vilma.scenario import load_scenario
from vilma.scenario.runner import run

ROOT = Path(__file__).resolve().parents[1]
ANCHOR = Path(__file__).parent / "anchors" / "reactive_planner.py"
FIELDS = ("goal_reached", "collisions", "off_road", "time_to_goal_s", "plan_ms_mean", "plan_ms_max", "cycles",
          "error")
ANCHOR_TIMEOUT_S = 3600.0
"""How long the reactive planner may take on one file [s] before its row says it hung."""


LASER = {"perception": "laser", "laser": "true"}
"""The overrides for laser perception (the scans segmented, boxed and tracked) instead of the objects sensor."""


def vilma_side(file: Path, overrides: dict[str, str] | None = None) -> dict:
    """vilma on ``file``: its default for a CommonRoad file, the ``plan`` task (perception, prediction and the
    sampling planner each 0.1 s), with ``overrides`` (``--set``)."""
    try:
        m = run(load_scenario(file, overrides)).metrics
    except Exception as e:  # a failure is a row, as on the reactive side
        return {"vilma_task": "plan", **dict.fromkeys(FIELDS), "goal_reached": False, "error": _line(e)}
    return {"vilma_task": "plan", **{k: m.get(k) for k in FIELDS[:4]}, "plan_ms_mean": m.get("planning_ms_mean"),
            "plan_ms_max": m.get("planning_ms_max"), "cycles": m.get("planning_cycles"), "error": None,
            "incomplete_reason": m.get("incomplete_reason")}


def reactive_side(file: Path) -> dict:
    """The reactive planner on ``file`` (:mod:`anchors.reactive_planner`), in a subprocess."""
    cmd = [sys.executable, "-W", "ignore", str(ANCHOR), str(file)]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=ANCHOR_TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired:
        return {**dict.fromkeys(FIELDS), "goal_reached": False, "error": f"no answer in {ANCHOR_TIMEOUT_S:g} s"}
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines() or ["no output"]
        last = next((x for x in reversed(lines) if "Error" in x), lines[-1])  # not the checker's leak report
        return {**dict.fromkeys(FIELDS), "goal_reached": False, "error": f"exit {done.returncode}: {last}"}
    row = json.loads(done.stdout)
    del row["file"]
    return row


def scenario_files(folder: Path) -> list[Path]:
    """The CommonRoad files of ``folder`` then the bundled ones, each content once."""
    bundled = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad"))
    files, seen = [], set()
    for f in [*sorted(folder.glob("*.xml")), *sorted(bundled.glob("*.xml"))]:
        digest = hashlib.sha256(f.read_bytes()).digest()
        if digest not in seen:
            seen.add(digest)
            files.append(f)
    return files


def markdown(rows: list[dict]) -> str:
    """The table of ``rows``: a line per file and side."""
    head = ("file", "side", *FIELDS)
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        for side in ("vilma", "vilma_laser", "reactive"):
            cells = [r["file"], side, *(_cell(r[side][k]) for k in FIELDS)]
            lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(v) -> str:
    return "" if v is None else f"{v:.3g}" if isinstance(v, float) else str(v)


def _line(e: BaseException) -> str:
    return (f"{type(e).__name__}: {e}".strip().splitlines() or [type(e).__name__])[0]


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenarios", type=Path, default=ROOT.parent / "shared" / "commonroad",
                        help="a folder of CommonRoad files (default: %(default)s)")
    args = parser.parse_args(argv)
    if not args.scenarios.is_dir():
        parser.error(f"--scenarios {args.scenarios}: not a folder; give the folder of the CommonRoad .xml files")
    if importlib.util.find_spec("commonroad_rp") is None:
        parser.error("commonroad-reactive-planner is not installed: pip install -e '.[benchmark]'")
    rows = []
    for f in scenario_files(args.scenarios):
        rows.append({"file": f.name, "path": str(f), "vilma": vilma_side(f), "vilma_laser": vilma_side(f, LASER),
                     "reactive": reactive_side(f)})
        print(f"{f.name}: done", file=sys.stderr)
    print(json.dumps(rows, indent=1))
    print(markdown(rows), file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
