"""Cost and size of recordings: prints JSON.

- ``one_hour_run``: a one-hour drive (speed task on a long straight, every sensor at its default rate) by
  :func:`vilma.scenario.runner.run` with its files, without and with ``run.mcap``, in ``REPEAT`` pairs.
  This machine's cores each change speed by up to 1.7 times for seconds at a time, so two runs one after
  the other differ by up to 20 % whatever they do. The two runs of a pair therefore take turns, a block of
  the compiled loop (5 s of sim time, a few ms of wall time) each, in two threads of one process: both see
  the same machine. Each run's time is the wall time it held the turn; the recording's cost is the
  with/without ratio, for the whole run and for its loop part (the blocks; the end, the plots mostly, is
  done in one go and so is noisier). ``recording_loop_thread_pct`` is the wall time the run spends in
  :class:`~vilma.record.run.RunRecorder` (starting the recorder's process, handing over, finishing) over the
  loop part of the run without: all the recording asks of the loop's thread; the recorder's process has a
  core of its own. Taking turns leaves the blocks colder when they are handed over, so both figures are a
  little above what a run alone pays. Targets (issue 7): cost <= 5 %, size < 200 MB an hour.
- ``closed_loop_alone_s``: the same drive compiled, no files at all (the loop's own speed).
- ``live``: ``vilma up``'s loop (simulator and driver on the local bus, every topic) unpaced for
  ``LIVE_SECONDS`` of sim time, with and without ``--record``, ``LIVE_REPEAT`` pairs: recording CPU per sim
  second, i.e. the share of a real-time loop's second it takes (median of the pairs).
"""

from __future__ import annotations

import json
import shutil
import statistics
import sys
import tempfile
import threading
import time
from pathlib import Path

from vilma.app import programs
from vilma.app.batch import BUNDLED
from vilma.record.reader import read_recording
from vilma.record.run import RunRecorder, record_run
from vilma.scenario.result import OnReadings
from vilma.scenario.runner import run
from vilma.scenario.spec import Scenario, load_scenario

LIVE_SECONDS = 120.0
LIVE_REPEAT = 5
REPEAT = 12


class _Turns:
    """Two runs, 0 and 1, take turns a block at a time; each sums the wall time it held the turn [s], and that
    of its last stretch (after its last block)."""

    def __init__(self, first: int) -> None:
        self._cond = threading.Condition()
        self._turn, self._done = first, [False, False]
        self.held, self.last, self._since = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]

    def take(self, i: int) -> None:
        with self._cond:
            self._cond.wait_for(lambda: self._turn == i or self._done[1 - i])
        self._since[i] = time.perf_counter()

    def give(self, i: int, done: bool = False) -> None:
        self.last[i] = time.perf_counter() - self._since[i]
        self.held[i] += self.last[i]
        with self._cond:
            self._turn, self._done[i] = 1 - i, done
            self._cond.notify_all()


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


def _pair(scenario: Scenario, tmp: Path, first: int) -> tuple[_Turns, float]:
    """A run without (0) and one with (1) its recording, taking turns from ``first``; and the time the second
    spent in the recorder [s]."""
    turns, failed = _Turns(first), []

    def drive(i: int) -> None:
        turns.take(i)

        def block(_) -> None:
            turns.give(i)
            turns.take(i)

        try:
            record_run(scenario, tmp / f"run{i}", record=bool(i), observers=[OnReadings(block)])
        except BaseException as e:
            failed.append(e)
        finally:
            turns.give(i, done=True)

    with _InRecorder() as rec:
        threads = [threading.Thread(target=drive, args=(i,)) for i in (0, 1)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    if failed:
        raise failed[0]
    return turns, rec.spent


def _hour(tmp: Path) -> dict:
    f = tmp / "hour.yaml"
    f.write_text("task: {speed: 15}\nduration: 3600\n", encoding="utf-8")
    scenario = load_scenario(f)
    r = record_run(scenario, tmp / "warm")  # numba caches, imports
    alone = statistics.median(_timed(lambda: run(scenario)) for _ in range(3))
    whole, loop, in_rec, held, plain_loop = [], [], [], [], []
    for i in range(REPEAT):
        turns, spent = _pair(scenario, tmp, i % 2)
        (plain, rec), (plain_end, rec_end) = turns.held, turns.last
        whole.append(100 * (rec / plain - 1))
        loop.append(100 * ((rec - rec_end) / (plain - plain_end) - 1))
        in_rec.append(spent)
        held.append((plain, rec))
        plain_loop.append(plain - plain_end)
        if i == 0:
            size = (tmp / "run1" / "run.mcap").stat().st_size
            back = read_recording(tmp / "run1" / "run.mcap")
        for d in ("run0", "run1"):  # an hour's files are hundreds of MB
            shutil.rmtree(tmp / d)
    messages = sum(back.count(t) for t in back.topics)
    med = statistics.median
    return {"sim_seconds": r.metrics["sim_time_s"], "pairs": REPEAT,
            "wall_s_without_recording": round(med(p for p, _ in held), 2),
            "wall_s_with_recording": round(med(w for _, w in held), 2),
            "recording_cost_pct": round(med(whole), 1),
            "recording_cost_pct_each": sorted(round(c, 1) for c in whole),
            "recording_cost_pct_loop_part": round(med(loop), 1),
            "recording_cost_pct_loop_part_each": sorted(round(c, 1) for c in loop),
            "recording_loop_thread_s": round(med(in_rec), 3),
            "recording_loop_thread_pct": round(med(100 * t / p for t, p in zip(in_rec, plain_loop, strict=True)), 1),
            "closed_loop_alone_s": round(alone, 2),
            "run_mcap_mb": round(size / 2**20, 1), "messages": messages, "bytes_per_message": round(size / messages, 1)}


def _timed(fn) -> float:
    """Wall time of ``fn()`` [s]."""
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _live(tmp: Path) -> dict:
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    cpu: dict[str, list[float]] = {"without": [], "with": []}
    for i in range(LIVE_REPEAT):  # in turn one first, then the other
        for name in ("without", "with")[::1 if i % 2 else -1]:
            c0 = time.process_time()
            programs.up(scenario, 1e6, LIVE_SECONDS, lambda _: None,
                        record=tmp / "live.mcap" if name == "with" else None)
            cpu[name].append((time.process_time() - c0) / LIVE_SECONDS)
    share = [100 * (w - p) for w, p in zip(cpu["with"], cpu["without"], strict=True)]
    return {"sim_seconds": LIVE_SECONDS, "pairs": LIVE_REPEAT,
            "loop_cpu_s_per_sim_s_without": round(statistics.median(cpu["without"]), 4),
            "loop_cpu_s_per_sim_s_with": round(statistics.median(cpu["with"]), 4),
            "recording_cpu_pct_of_real_time": round(statistics.median(share), 2),
            "recording_cpu_pct_of_real_time_each": sorted(round(c, 2) for c in share),
            "mb_per_hour": round((tmp / "live.mcap").stat().st_size / 2**20 * 3600 / LIVE_SECONDS, 1)}


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        out = {"benchmark": "record", "one_hour_run": _hour(tmp), "live": _live(tmp)}
    json.dump(out, sys.stdout, indent=2)
    print()


if __name__ == "__main__":
    main()
