"""Do the bundled scenarios give the same scorecards as at another commit? (a refactoring's check)

    python benchmarks/same_scorecards.py BASE_REF [SCENARIO ...]

Checks out ``BASE_REF`` in a temporary git worktree, runs ``vilma run`` on every bundled scenario (or the
ones named) with that tree's code and with this tree's, and compares each run's ``metrics.json`` key by
key (the timing keys aside: they measure this machine) and its ``timeseries.csv`` byte for byte. Prints
JSON, one entry per scenario, and exits 1 if any differs.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TIMING_KEYS = {"wall_time_s", "loop_wall_time_s", "load_time_s", "realtime_factor", "controller_time_per_step_us",
               "planning_ms_mean", "planning_ms_max"}


def bundled(tree: Path) -> list[str]:
    """The bundled scenario names of a tree."""
    return sorted(p.stem for p in (tree / "src/vilma/scenarios").glob("*.yaml"))


def run_all(tree: Path, names: list[str], out: Path) -> None:
    """``vilma run`` with ``tree``'s code on ``names``, each into ``out/<name>``."""
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "NUMBA_CACHE_DIR": str(out.parent / (out.name + "-numba"))}
    cmd = [sys.executable, "-m", "vilma", "run", "-q", "--no-record", "--out", str(out), *names]
    subprocess.run(cmd, env=env, cwd=tree, check=False, stdout=subprocess.DEVNULL)


def compare(a: Path, b: Path) -> dict:
    """The differences between two run folders: metric keys that differ, and whether the series match."""
    if not (a / "metrics.json").exists() or not (b / "metrics.json").exists():
        return {"missing": [str(p) for p in (a, b) if not (p / "metrics.json").exists()]}
    ma, mb = (json.loads((p / "metrics.json").read_text()) for p in (a, b))
    keys = sorted((set(ma) | set(mb)) - TIMING_KEYS)
    diff = {k: [ma.get(k), mb.get(k)] for k in keys if ma.get(k) != mb.get(k)}
    same_series = (a / "timeseries.csv").read_bytes() == (b / "timeseries.csv").read_bytes()
    return {"metrics_differ": diff, "timeseries_identical": same_series} if diff or not same_series else {}


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__, file=sys.stderr)
        return 2
    base, names = argv[0], argv[1:]
    with tempfile.TemporaryDirectory(prefix="vilma-same-") as tmp:
        tmp = Path(tmp)
        tree = tmp / "base"
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(tree), base], cwd=ROOT, check=True)
        try:
            names = names or sorted(set(bundled(tree)) & set(bundled(ROOT)))
            run_all(tree, names, tmp / "before")
            run_all(ROOT, names, tmp / "after")
            one = len(names) == 1
            result = {n: compare(tmp / "before" / ("" if one else n), tmp / "after" / ("" if one else n))
                      for n in names}
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT, check=False)
    same = all(not r for r in result.values())
    print(json.dumps({"base": base, "identical": same, "scenarios": {n: r or "identical" for n, r in result.items()}},
                     indent=1))
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
