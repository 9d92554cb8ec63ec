"""What a user waits for: whole ``vilma`` commands against a plain-numpy script of the same drive; prints JSON.

- ``anchor``: ``benchmarks/anchors/numpy_stanley.py``, the ``course_30kmh_stanley`` drive written by hand with
  numpy and scipy (course, car, Stanley, PI, CSV), run as its own process.
- ``run``: ``vilma run course_30kmh_stanley`` with its default files (timeseries, scorecard, run.mcap; plots are
  drawn on request), caches warm, in its own process; ``run_bare``: the same with ``--no-record``; ``run_plots``:
  with ``--plots`` (the four PNGs too); ``help``: ``vilma --help``.
- ``numba_floor``: ``benchmarks/anchors/numba_floor.py``, a process that only loads one cached numba function as a
  ``vilma`` command starts numba: what any command of a numba-compiled program pays at least (``floor_to_anchor``:
  over the anchor's time; above 1.0, no such command can meet the 1.0x target in its own process).
- ``run_served``, ``run_bare_served``, ``run_plots_served``: the same commands while ``vilma serve`` listens
  (started here, warmed up on the same scenario): the command is a client, the run a child forked from the warm
  server.

Each is run as a fresh process with the caches warm (numba's, the OS's and Python's bytecode: a variable
``PYTHONDONTWRITEBYTECODE`` is dropped, as an installed package's modules are compiled when pip installs them),
interleaved, ``ROUNDS`` times (this machine's speed varies 2x); the figures are
medians of wall seconds and CPU seconds (user + system of the process and its children), and the ratios to the
anchor's wall time. Targets (issue 21): ``run`` <= 1.5x, ``run_bare`` <= 1.0x, ``help`` < 0.15 s (the served
cases against the same targets).

    python benchmarks/whole_command.py [ROUNDS]
"""

from __future__ import annotations

import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ANCHOR = Path(__file__).parent / "anchors" / "numpy_stanley.py"
VILMA = [sys.executable, "-m", "vilma"]
TARGETS = {"run": 1.5, "run_bare": 1.0, "run_served": 1.5, "run_bare_served": 1.0}
HELP_TARGET_S = 0.15


def _timed(argv: list[str], cwd: str, env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU seconds [s] of the process ``argv`` (and its children, not a server's), which must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _rounds(rounds: int, tmp: str, alone: dict[str, str], served: dict[str, str]) -> dict[str, list]:
    """Each case's (wall, CPU) seconds, ``rounds`` times, interleaved, after one untimed warm-up each."""
    cases = {
        "anchor": [sys.executable, str(ANCHOR), os.path.join(tmp, "anchor.csv")],
        "run": [*VILMA, "run", "course_30kmh_stanley", "--out", os.path.join(tmp, "run"), "--overwrite", "-q"],
        "run_bare": [*VILMA, "run", "course_30kmh_stanley", "--out", os.path.join(tmp, "bare"), "--overwrite",
                     "--no-record", "-q"],
        "run_plots": [*VILMA, "run", "course_30kmh_stanley", "--out", os.path.join(tmp, "plots"), "--overwrite",
                      "--plots", "-q"],
        "help": [*VILMA, "--help"],
        "numba_floor": [sys.executable, str(ANCHOR.with_name("numba_floor.py"))],
    }
    cases |= {f"{k}_served": v for k, v in cases.items() if k.startswith("run")}
    envs = {k: served if k.endswith("_served") else alone for k in cases}
    for name, argv in cases.items():  # warm the caches (numba's, the OS's) outside the timing
        _timed(argv, tmp, envs[name])
    times: dict[str, list[tuple[float, float]]] = {k: [] for k in cases}
    for _ in range(rounds):
        for name, argv in cases.items():
            times[name].append(_timed(argv, tmp, envs[name]))
    return times


def main(rounds: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}  # Python's cache is warm too
        alone, served = {**env, "VILMA_SERVE": "off"}, {**env, "VILMA_SERVE": os.path.join(tmp, "s")}
        server = subprocess.Popen([*VILMA, "serve"], env=served, stdout=subprocess.PIPE, text=True)
        try:
            next(line for line in server.stdout if "Ctrl-C ends" in line)
            times = _rounds(rounds, tmp, alone, served)
        finally:
            server.terminate()
            server.wait()
    wall = {k: statistics.median(w for w, _ in v) for k, v in times.items()}
    cpu = {k: statistics.median(c for _, c in v) for k, v in times.items()}
    out = {"benchmark": "whole_command", "rounds": rounds, "cpus": os.cpu_count(),
           "wall_s": {k: round(v, 3) for k, v in wall.items()}, "cpu_s": {k: round(v, 3) for k, v in cpu.items()},
           "ratio_to_anchor": {k: round(wall[k] / wall["anchor"], 2) for k in wall if k.startswith("run")},
           "floor_to_anchor": round(wall["numba_floor"] / wall["anchor"], 2),
           "target_ratio": TARGETS, "help_target_s": HELP_TARGET_S,
           "meets": {**{k: wall[k] / wall["anchor"] <= TARGETS[k] for k in TARGETS},
                     "help": wall["help"] < HELP_TARGET_S}}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5)
