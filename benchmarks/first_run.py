"""A first run on a fresh install: ``vilma run`` with no compiled caches yet; prints JSON.

``vilma run course_30kmh_stanley --no-plots --no-record`` in its own process, with an empty numba cache
(``NUMBA_CACHE_DIR``) and an empty vilma cache (``VILMA_CACHE_DIR``: the spline course), as after ``pip install``:
the CPU seconds (user + system of the process) and wall seconds it takes, each of ``ROUNDS`` rounds with fresh
caches, then the same command once more with the caches it left (a warm run, for scale). Target (issue 21): under
15 s of CPU.

    python benchmarks/first_run.py [ROUNDS]
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

COMMAND = [sys.executable, "-m", "vilma", "run", "course_30kmh_stanley", "--no-plots", "--no-record"]
TARGET_CPU_S = 15.0
ROUNDS = 2


def _timed(env: dict[str, str], cwd: str) -> tuple[float, float]:
    """CPU and wall seconds [s] of one ``COMMAND`` in ``cwd`` with ``env``, which must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(COMMAND, cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, wall


def main(rounds: int) -> None:
    cold, warm = [], []
    for _ in range(rounds):
        with tempfile.TemporaryDirectory() as tmp:
            env = {**os.environ, "NUMBA_CACHE_DIR": os.path.join(tmp, "numba"),
                   "VILMA_CACHE_DIR": os.path.join(tmp, "vilma")}
            cold.append(_timed(env, tmp))
            warm.append(_timed(env, tmp))
    cpu = [c for c, _ in cold]
    print(json.dumps({
        "command": " ".join(["vilma", *COMMAND[3:]]), "rounds": rounds,
        "first_run_cpu_s": [round(c, 2) for c in cpu], "first_run_wall_s": [round(w, 2) for _, w in cold],
        "first_run_cpu_median_s": round(statistics.median(cpu), 2), "target_cpu_s": TARGET_CPU_S,
        "meets_target": statistics.median(cpu) < TARGET_CPU_S,
        "warm_run_cpu_s": [round(c, 2) for c, _ in warm], "warm_run_wall_s": [round(w, 2) for _, w in warm],
    }, indent=2))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else ROUNDS)
