"""The run's plots: ``plot_run`` now against the way it drew them before (issue 21); prints JSON.

- ``before``: ``src/vilma/scenario/report.py`` at ``ANCHOR`` (pyplot figures, constrained layout, saved with
  ``bbox_inches="tight"``: each figure laid out and drawn two or three times), loaded from git.
- ``after``: today's :func:`vilma.scenario.report.plot_run` (a Figure on its own Agg canvas, fixed margins, one
  draw per PNG).

Both write the four PNGs of a ``course_30kmh_stanley`` run and of a ``commonroad_tutorial`` run (one drive each,
in this process), warmed once, then timed interleaved ``ROUNDS`` times; the figures are medians of wall seconds
and of this process's CPU seconds (steadier on a shared machine).
``import_s`` is the cost of importing what each needs of matplotlib (``before``: pyplot; ``after``: the figure and
the Agg canvas), each in a fresh interpreter with numpy already loaded, also medians.

    python benchmarks/plots.py [ROUNDS]
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

from vilma.app.batch import find_scenario
from vilma.scenario import report
from vilma.scenario.folder import speed_log
from vilma.scenario.runner import run
from vilma.scenario.spec import load_scenario

ANCHOR = "7722378373eb59ffeeb530e0d6ce04d566ec7afc"
"""The last commit with pyplot's plots."""
SCENARIOS = ("course_30kmh_stanley", "commonroad_tutorial")
IMPORTS = {"before": "import matplotlib; matplotlib.use('Agg'); import matplotlib.pyplot",
           "after": "import matplotlib.figure, matplotlib.backends.backend_agg"}


def anchor_module() -> types.ModuleType:
    """``vilma.scenario.report`` as it was at ``ANCHOR``."""
    root = Path(__file__).resolve().parents[1]
    src = subprocess.run(["git", "-C", str(root), "show", f"{ANCHOR}:src/vilma/scenario/report.py"], check=True,
                         capture_output=True, text=True).stdout
    module = types.ModuleType("report_before")
    exec(compile(src, "report_before.py", "exec"), module.__dict__)
    return module


def import_seconds(statement: str) -> float:
    """Wall seconds [s] that ``statement`` takes in a fresh interpreter that has imported numpy."""
    code = f"import numpy, time; t = time.perf_counter(); {statement}; print(time.perf_counter() - t)"
    return float(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout)


def main(rounds: int) -> None:
    plotters = {"before": anchor_module().plot_run, "after": report.plot_run}
    runs = {}
    for name in SCENARIOS:
        sc = load_scenario(find_scenario(name))
        runs[name] = (run(sc), speed_log(sc))
    cases = {(name, way): (plot, *runs[name]) for name in SCENARIOS for way, plot in plotters.items()}
    times: dict[tuple[str, str], list[tuple[float, float]]] = {k: [] for k in cases}
    imports: dict[str, list[float]] = {k: [] for k in IMPORTS}
    with tempfile.TemporaryDirectory() as tmp:
        for plot, result, log in cases.values():  # fonts, text layouts: warm for both, outside the timing
            plot(result, Path(tmp), log)
        for _ in range(rounds):
            for key, (plot, result, log) in cases.items():
                t0, c0 = time.perf_counter(), time.process_time()
                plot(result, Path(tmp), log)
                times[key].append((time.perf_counter() - t0, time.process_time() - c0))
            for way, statement in IMPORTS.items():
                imports[way].append(import_seconds(statement))
    wall, cpu = ({name: {way: round(statistics.median(s[i] for s in times[name, way]), 3) for way in plotters}
                  for name in SCENARIOS} for i in (0, 1))
    out = {"benchmark": "plots", "rounds": rounds, "plot_run_wall_s": wall, "plot_run_cpu_s": cpu,
           "speedup": {name: round(w["before"] / w["after"], 1) for name, w in wall.items()},
           "import_s": {way: round(statistics.median(v), 3) for way, v in imports.items()}}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
