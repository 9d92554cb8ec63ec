"""Cost and size of recordings: prints JSON.

- ``one_hour_run``: a one-hour drive (speed task on a long straight, every sensor at its default rate) by
  :func:`vilma.scenario.runner.run` with its files, with and without ``run.mcap``, in ``REPEAT`` pairs (in
  turn one first, then the other: the machine's speed drifts); the recording's share of the wall time
  (median of the pairs, and each; and the best run of each kind compared), of the main thread's CPU time,
  its size and message count. Targets (issue 7): cost <= 5 %, size < 200 MB an hour.
  The machine's cores each change speed by up to 1.7 times for seconds at a time, so a pair's runs can
  differ by 20 % with or without recording. ``recording_loop_thread_*`` is steadier: the wall time the run's
  thread spends in :class:`~vilma.record.run.RunRecorder` (starting the recorder's process, handing over,
  finishing), which is all the recording asks of the loop's thread (the recorder's process has a core of
  its own).
- ``closed_loop_alone_s``: the same drive compiled, no files at all (the loop's own speed).
- ``live``: ``vilma up``'s loop (simulator and driver on the local bus, every topic) unpaced for
  ``LIVE_SECONDS`` of sim time, with and without ``--record``: recording CPU per sim second, i.e. the
  share of a real-time loop's second it takes.
"""

from __future__ import annotations

import json
import math
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

from vilma import programs
from vilma.record.reader import read_recording
from vilma.record.run import RunRecorder
from vilma.scenario.batch import BUNDLED
from vilma.scenario.runner import run
from vilma.scenario.spec import load_scenario

LIVE_SECONDS = 120.0
REPEAT = 16


def _timed(fn) -> tuple[float, float]:
    """Wall time and this thread's CPU time of ``fn()`` [s]."""
    t0, c0 = time.perf_counter(), time.thread_time()
    fn()
    return time.perf_counter() - t0, time.thread_time() - c0


class _InRecorder:
    """Sums the wall time spent in :class:`RunRecorder`'s methods while in use [s] (none calls another)."""

    METHODS = ("__init__", "add", "add_captures", "finish", "close", "abort")

    def __enter__(self) -> _InRecorder:
        self.spent, self._saved = 0.0, {m: getattr(RunRecorder, m) for m in self.METHODS}
        for m, fn in self._saved.items():
            setattr(RunRecorder, m, self._timed(fn))
        return self

    def __exit__(self, *exc) -> None:
        for m, fn in self._saved.items():
            setattr(RunRecorder, m, fn)

    def _timed(self, fn):
        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.spent += time.perf_counter() - t0
        return timed


def _recorded(scenario, out_dir: Path) -> tuple[float, float, float]:
    """Wall and CPU time of a run with its recording [s], and the time its thread spent in the recorder's calls."""
    with _InRecorder() as rec:
        wall, cpu = _timed(lambda: run(scenario, out_dir=out_dir))
    return wall, cpu, rec.spent


def _hour(tmp: Path) -> dict:
    f = tmp / "hour.yaml"
    f.write_text("task: {speed: 15}\nduration: 3600\n", encoding="utf-8")
    scenario = load_scenario(f)
    r = run(scenario, out_dir=tmp / "warm")  # numba caches, imports
    alone = [_timed(lambda: run(scenario))[0] for _ in range(3)]
    plain, with_rec = [], []
    for i in range(REPEAT):
        pair = [(plain, lambda i=i: _timed(lambda: run(scenario, out_dir=tmp / f"plain{i}", record=False))),
                (with_rec, lambda i=i: _recorded(scenario, tmp / f"rec{i}"))]
        for out, go in pair[::1 if i % 2 else -1]:
            out.append(go())
        for name in (f"plain{i}", f"rec{i}")[:None if i else 1]:  # an hour's files are hundreds of MB: keep rec0
            shutil.rmtree(tmp / name)
    cost = [100 * (w[0] - p[0]) / p[0] for w, p in zip(with_rec, plain, strict=True)]
    cpu = [100 * (w[1] - p[1]) / p[1] for w, p in zip(with_rec, plain, strict=True)]
    size = (tmp / "rec0" / "run.mcap").stat().st_size
    back = read_recording(tmp / "rec0" / "run.mcap")
    messages = sum(back.count(t) for t in back.topics)
    med = statistics.median
    plain_s, rec_s = med(p[0] for p in plain), med(w[0] for w in with_rec)
    return {"sim_seconds": r.metrics["sim_time_s"], "repeats": REPEAT,
            "wall_s_files_without_recording": round(plain_s, 2),
            "wall_s_files_with_recording": round(rec_s, 2),
            "recording_cost_pct_of_run_with_files": round(med(cost), 1),
            "recording_cost_pct_each": sorted(round(c, 1) for c in cost),
            "recording_cost_pct_best_of_runs": round(100 * (min(w[0] for w in with_rec) / min(p[0] for p in plain)
                                                            - 1), 1),
            "wall_s_each": {"without": [round(p[0], 2) for p in plain], "with": [round(w[0], 2) for w in with_rec]},
            "recording_main_thread_cpu_pct": round(med(cpu), 1),
            "recording_loop_thread_s": round(med(w[2] for w in with_rec), 3),
            "recording_loop_thread_pct_of_run_with_files": round(
                med(100 * w[2] / p[0] for w, p in zip(with_rec, plain, strict=True)), 1),
            "recording_loop_thread_pct_of_compiled_loop_alone": round(
                100 * med(w[2] for w in with_rec) / med(alone), 1),
            "recording_cost_pct_of_compiled_loop_alone": round(100 * (rec_s - plain_s) / med(alone), 1),
            "closed_loop_alone_s": round(med(alone), 2), "run_mcap_mb": round(size / 2**20, 1),
            "messages": messages, "bytes_per_message": round(size / messages, 1)}


def _live(tmp: Path) -> dict:
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    out = {}
    for name, record in (("without", None), ("with", tmp / "live.mcap")):
        t0, c0 = time.perf_counter(), time.process_time()
        programs.up(scenario, 1e6, LIVE_SECONDS, lambda _: None, record=record)
        out[name] = (time.perf_counter() - t0, time.process_time() - c0)
    cpu = (out["with"][1] - out["without"][1]) / LIVE_SECONDS
    return {"sim_seconds": LIVE_SECONDS, "loop_cpu_s_per_sim_s_without": round(out["without"][1] / LIVE_SECONDS, 4),
            "loop_cpu_s_per_sim_s_with": round(out["with"][1] / LIVE_SECONDS, 4),
            "recording_cpu_pct_of_real_time": round(100 * cpu, 2) if math.isfinite(cpu) else None,
            "recording_cost_pct_of_unpaced_loop": round(100 * (out["with"][0] - out["without"][0])
                                                        / out["without"][0], 1),
            "mb_per_hour": round((tmp / "live.mcap").stat().st_size / 2**20 * 3600 / LIVE_SECONDS, 1)}


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        out = {"benchmark": "record", "one_hour_run": _hour(tmp), "live": _live(tmp)}
    json.dump(out, sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
