"""Several runs in a row: scenario files times a ``--set`` sweep, a progress bar, one summary table."""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from numba.core.event import Listener, install_listener

from vilma.app import collector
from vilma.core.numba_start import load_array_support
from vilma.record.run import record_run
from vilma.scenario.bundled import BUNDLED as BUNDLED  # re-exported: where the demo and the tests find them
from vilma.scenario.bundled import find_scenario as find_scenario
from vilma.scenario.fields import SpecError
from vilma.scenario.folder import RunFolder, claim, clear, folder_name, write_metrics
from vilma.scenario.result import RunObserver, RunResult
from vilma.scenario.spec import Scenario, load_scenario

if TYPE_CHECKING:  # rich is imported where a table or a bar is drawn: a quiet run draws none (12-19 ms of its start)
    from rich.console import Console
    from rich.progress import Progress, TaskID
    from rich.table import Table
    from rich.text import Text

SUMMARY = (("completed", "done"), ("lateral_error_rms_m", "lat RMS [m]"), ("lateral_error_max_m", "lat max [m]"),
           ("speed_rise_time_90_s", "t90 [s]"), ("speed_overshoot_pct", "overshoot [%]"),
           ("speed_error_rms_mps", "speed RMS [m/s]"), ("pose_error_rms_m", "pose RMS [m]"),
           ("realtime_factor", "x real time"))
"""Scorecard keys shown in the summary table, with their headings."""
COMPILING = ("compiling vilma's numba code for this machine, once: 15 s for a scenario's kernels, up to a minute for "
             "many kinds (cached for the next runs)")
"""What a command says when numba first compiles one of vilma's functions in it (:class:`_Compiling`)."""
MAX_RUNS = 100_000
"""Runs one ``--set`` sweep may ask for (each is loaded and checked before the first starts)."""

load_array_support()  # before the first kernel loads: spares a command scipy.linalg's import


@dataclass(frozen=True, slots=True)
class Job:
    """One run to make: a scenario and the ``--set`` values it was loaded with."""

    scenario: Scenario
    overrides: tuple[tuple[str, str], ...] = ()

    @property
    def label(self) -> str:
        """The ``--set`` values, ``key=value ...``."""
        return " ".join(f"{k}={v}" for k, v in self.overrides)


def parse_sets(items: Sequence[str]) -> list[dict[str, str]]:
    """``key=value`` strings to the override sets to run: ``key=a,b,c`` sweeps (every combination).

    A value in brackets (``key=[1, 2]``) is one YAML list, not a sweep.
    """
    axes: list[list[tuple[str, str]]] = []
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise SpecError(f"--set {item}: expected key=value, e.g. --set task.speed=10")
        value = value.strip()
        values = [value] if value.startswith(("[", "{")) else [v.strip() for v in value.split(",")]
        axes.append([(key.strip(), v) for v in values])
    runs = math.prod(len(a) for a in axes)
    if runs > MAX_RUNS:
        raise SpecError(f"--set: {runs:.3g} runs in all, more than {MAX_RUNS}; sweep fewer values in one command")
    return [dict(combo) for combo in itertools.product(*axes)]


def plan(files: Sequence[str], sets: Sequence[str]) -> list[Job]:
    """Load and validate every run before the first starts (a bad file stops the batch before it runs).

    A name that is not a file but a bundled scenario's (``paper_fig11_speed_10``) runs that one.
    """
    jobs = []
    for f in files:
        for overrides in parse_sets(sets):
            jobs.append(Job(load_scenario(f, overrides), tuple(overrides.items())))
    return jobs


def as_cars(jobs: Sequence[Job], cars: int) -> list[Job]:
    """Each job as ``cars`` cars: its scenario with the seeds ``seed``, ``seed + 1`` ... (``seed=`` in the label)."""
    if len(jobs) * cars > MAX_RUNS:
        raise SpecError(f"--cars: {len(jobs) * cars:.3g} cars in all, more than {MAX_RUNS}; ask for fewer")
    out = []
    for job in jobs:
        sim = job.scenario.sim
        for k in range(cars):
            seed = sim.seed + k
            out.append(Job(dataclasses.replace(job.scenario, sim=dataclasses.replace(sim, seed=seed)),
                           (*((key, v) for key, v in job.overrides if key != "seed"), ("seed", str(seed)))))
    return out


def run_cars(jobs: list[Job], out: Path | None, console: Console, overwrite: bool = False) -> list[RunResult]:
    """Run the jobs side by side in the compiled loop (:func:`~vilma.scenario.fleet.run_fleet`), each writing its
    folder (:func:`out_dirs`) without plots or recording: ``timeseries.csv``, ``scenario.yaml``, ``metrics.json``."""
    from vilma.scenario.fleet import run_fleet

    dirs = claim_dirs(jobs, out, overwrite)
    collector.started()  # (the cars' objects come and go as usual)
    written = 0

    def wave_done(results: list[RunResult]) -> None:  # each car's scorecard once its wave is done: an interrupt
        nonlocal written  # keeps the cars of the waves before whole
        for r in results[written:]:
            write_metrics(r, dirs[written])
            written += 1
        bar.show(task, done=written)

    def folder(i: int, _) -> tuple[RunFolder]:  # as the car's wave starts
        clear(dirs[i])
        return (RunFolder(dirs[i], plots=False),)

    with _Bar(console, True) as bar, install_listener("numba:compile", _Compiling(console, bar)):
        task = bar.add(f"{len(jobs)} cars", len(jobs))
        try:
            return run_fleet([j.scenario for j in jobs], folder, wave_done)
        except KeyboardInterrupt:
            raise KeyboardInterrupt(f"interrupted: {written} of {len(jobs)} cars done, partial files in "
                                    f"{out if out is not None else dirs[0].parent}") from None


def run_all(jobs: list[Job], out: Path | None, realtime: float | None, console: Console,
            observers: Callable[[Scenario], Sequence[RunObserver]] = lambda _: (), record: bool = True,
            plots: bool = True, overwrite: bool = False, started: float | None = None) -> list[RunResult]:
    """Run the jobs in order with a progress bar, writing each run's files (``run.mcap`` too, if ``record``; the
    plots if ``plots``) into its own folder (:func:`out_dirs`); returns the results.

    A folder that holds anything (a batch's ``out`` too) stops the batch before it runs, unless ``overwrite`` (then
    the earlier run's files go first). The ``observers`` of a scenario watch its run as it goes (see
    :func:`~vilma.scenario.runner.run`); ``started`` is when the command began (:func:`time.perf_counter`),
    counted in the first run's ``wall_time_s``.
    """
    dirs = claim_dirs(jobs, out, overwrite)
    if realtime is not None:  # a paced run lasts: the collector as usual from the start
        collector.started()
    results = []
    bar = _Bar(console, len(jobs) > 1)
    compiling = _Compiling(console, bar)
    with bar, install_listener("numba:compile", compiling):
        task = bar.add("running", len(jobs), visible=len(jobs) > 1)
        for i, (job, out_dir) in enumerate(zip(jobs, dirs, strict=True), 1):
            name = job.scenario.name + (f" {job.label}" if job.label else "")
            bar.show(task, name)
            t0 = time.perf_counter()
            clear(out_dir)
            r = record_run(job.scenario, out_dir, record=record, plots=plots, realtime=realtime,
                           observers=observers(job.scenario), started=started)
            results.append(r)
            collector.started()  # (the first run ends the command's start)
            compiling.finished()
            started = time.perf_counter()  # each run's share of the command starts where the last one's ended
            bar.show(task, done=i)
            if not console.is_terminal:  # a log or a pipe: a line a run instead of the bar
                verdict = "pass" if r.passed else "FAIL"
                console.print(f"[{i}/{len(jobs)}] {name}: {verdict} in {started - t0:.1f} s", markup=False,
                              highlight=False)
    return results


class Quiet:
    """What a command with ``--quiet`` prints to: nothing (rich's ``Console(quiet=True)``, without rich's import)."""

    quiet, is_terminal = True, False

    def print(self, *objects, **options) -> None:
        """Nothing."""


class _Bar:
    """rich's transient progress bar on ``console`` within a ``with`` block: from its start when ``shown``, else from
    the first :meth:`start`; never outside a terminal (rich's progress is then not imported)."""

    def __init__(self, console: Console, shown: bool) -> None:
        self.console, self.shown = console, shown
        self.progress: Progress | None = None

    def __enter__(self) -> _Bar:
        if self.shown:
            self.start()
        return self

    def __exit__(self, *exc) -> None:
        if self.progress is not None:
            self.progress.stop()

    def start(self) -> Progress | None:
        """The bar, shown from now on in a terminal (None elsewhere)."""
        if self.progress is None and self.console.is_terminal:
            from rich.progress import Progress

            self.progress = Progress(console=self.console, transient=True)
            self.progress.start()
        return self.progress

    def add(self, description: str, total: int, visible: bool = True) -> TaskID | None:
        """A new line of the bar (None when not shown)."""
        return self.progress.add_task(description, total=total, visible=visible) if self.progress else None

    def show(self, task: TaskID | None, text: str | None = None, done: int | None = None) -> None:
        """Say ``text`` (as it is: no markup) on the line ``task``, and that ``done`` of its total are done (nothing
        for a line :meth:`add` did not make: the bar was not shown then)."""
        if task is not None:
            from rich.text import Text

            self.progress.update(task, description=Text(text) if text is not None else None, completed=done)


def claim_dirs(jobs: Sequence[Job], out: Path | None, overwrite: bool) -> list[Path]:
    """Each run's folder (:func:`out_dirs`), claimed (:func:`~vilma.scenario.folder.claim`) with a batch's ``out``:
    a batch's folder, as a single run's, must be new or empty unless ``overwrite``. The earlier run's files in each
    are not removed yet: :func:`~vilma.scenario.folder.clear` as the run starts (an interrupted batch keeps those of
    the runs it did not reach)."""
    dirs = out_dirs(jobs, out)
    if out is not None and dirs != [out]:
        claim([out], overwrite)  # (an earlier single run's files there go now)
    claim(dirs, overwrite, clear_now=False)
    return dirs


def out_dirs(jobs: Sequence[Job], out: Path | None) -> list[Path]:
    """Each run's folder: ``out`` for a single run, else ``<out>/<name>`` (``runs/<name>-<timestamp>``
    without ``out``); a name is the scenario's, its ``--set`` values, and where two runs would still share
    it, the scenario file's folder, then ``-2``, ``-3``... Each name is one folder inside the root
    (:func:`~vilma.scenario.folder.folder_name`), whatever the scenario calls itself."""
    if out is not None and len(jobs) == 1:
        return [out]
    names = [folder_name(job.scenario.name + "".join(f"-{k}_{v}" for k, v in job.overrides)) for job in jobs]
    files: dict[str, set] = {}
    for job, n in zip(jobs, names, strict=True):
        files.setdefault(n, set()).add(job.scenario.file)
    names = [folder_name(f"{job.scenario.file.resolve().parent.name}-{n}")
             if len(files[n]) > 1 and job.scenario.file else n for job, n in zip(jobs, names, strict=True)]
    seen: Counter[str] = Counter()
    unique = []
    for n in names:
        seen[n] += 1
        unique.append(n if seen[n] == 1 else f"{n}-{seen[n]}")
    if out is None:
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S-%f")
        return [Path("runs") / f"{n}-{stamp}" for n in unique]
    return [out / n for n in unique]


class _Compiling(Listener):
    """What a command says while numba compiles vilma's functions (numba's event API: a first run on a fresh install,
    or after an edit): at the first, :data:`COMPILING` once; in a terminal, a progress line under it of how many are
    done, and which now, until the run ends (:meth:`finished`)."""

    def __init__(self, console: Console, bar: _Bar) -> None:
        self.console, self.bar, self.done, self.task, self.said = console, bar, 0, None, False

    def on_start(self, event) -> None:
        name = _vilmas(event)
        if name is None:
            return
        if not self.said:
            self.console.print(COMPILING, highlight=False)
            self.said = True
        progress = self.bar.start()
        if progress is None:
            return
        if self.task is None:
            self.task = progress.add_task("", total=None)
        from rich.text import Text

        progress.update(self.task, description=Text(f"compiling, once: {self.done} of vilma's functions done, "
                                                    f"now {name}"))

    def on_end(self, event) -> None:
        self.done += _vilmas(event) is not None

    def finished(self) -> None:
        """A run is over: its line goes (the next run that compiles has one again)."""
        if self.task is not None:
            self.bar.progress.remove_task(self.task)
        self.task = None


def _vilmas(event) -> str | None:
    """The name of the function a ``numba:compile`` event compiles, if it is vilma's (not numba's own)."""
    fn = getattr(event.data.get("dispatcher"), "py_func", None)
    return fn.__qualname__ if getattr(fn, "__module__", "").startswith("vilma.") else None


def scorecard_table(result: RunResult) -> Table:
    """Every scorecard key of one run, with its value."""
    from rich.table import Table

    table = Table(title=f"{result.scenario.name}: scorecard", show_header=True)
    table.add_column("metric")
    table.add_column("value", justify="right")
    for k, v in result.metrics.items():
        table.add_row(k, _fmt(v))
    return table


def summary_table(jobs: list[Job], results: list[RunResult]) -> Table:
    """One row per run: the :data:`SUMMARY` keys and pass or fail (and which planner and perception drove a
    planned run)."""
    from rich.table import Table
    from rich.text import Text

    table = Table(title="vilma run: summary")
    table.add_column("run")
    for _, heading in SUMMARY:
        table.add_column(Text(heading), justify="right")
    table.add_column("pass", justify="right")
    planned = any(r.metrics.get("planner") for r in results)
    if planned:  # which planner and perception drove
        table.add_column("planned by")
    why = any(r.metrics["incomplete_reason"] for r in results)
    if why:
        table.add_column("why not done")
    for job, r in zip(jobs, results, strict=True):
        name = r.scenario.name + (f" [{job.label}]" if job.label else "")
        m = r.metrics
        by = f"{m['planner']}, {m['perception']} perception" if m.get("planner") else "-"
        table.add_row(Text(name), *(_fmt(m[k]) for k, _ in SUMMARY), "yes" if r.passed else "NO",
                      *([Text(by)] if planned else []), *([Text(m["incomplete_reason"] or "")] if why else []))
    return table


def _fmt(v) -> Text | str:
    from rich.text import Text

    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    return Text(v) if isinstance(v, str) else f"{v:.4g}"
