"""Sweeps on Dask: the runs of a plan (:mod:`vilma.app.sweep_plan`) on a dask.distributed cluster, a row each.

Runs go to a :class:`distributed.LocalCluster` (a process a core) or to a running scheduler; each run is a row of the
results table (the :data:`~vilma.app.sweep_plan.IDENTITY` keys, the swept values, every scorecard key, the worker,
its error if it failed), appended to ``rows.jsonl`` as it arrives and written whole as ``results.parquet`` and
``results.csv`` at the end or on an interrupt. ``--resume`` runs the keys with no row (or a failed one), and a run
Dask reschedules after a lost worker is kept once.
"""

from __future__ import annotations

import argparse
import asyncio
import concurrent.futures
import contextlib
import dataclasses
import itertools
import json
import logging
import os
import signal
import threading
import time
import uuid
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import pandas as pd
from distributed import Client, LocalCluster, Security, as_completed, get_worker
from distributed.comm import connect as connect_comm
from distributed.comm import parse_address
from distributed.diagnostics.plugin import WorkerPlugin
from rich.console import Console
from rich.progress import BarColumn, Progress, ProgressColumn, TaskProgressColumn, TextColumn, TimeRemainingColumn
from rich.table import Table
from rich.text import Text

import vilma
from vilma.app.sweep_plan import IDENTITY, SweepRun, plan_sets, read_sweep
from vilma.core.extras import EXTRAS
from vilma.core.files import atomic_path, write_error
from vilma.record.run import record_run
from vilma.scenario.fields import SpecError
from vilma.scenario.report import agg_figure, write_png
from vilma.scenario.runner import run
from vilma.scenario.scorecard import SCORECARD_KEYS
from vilma.scenario.spec import Scenario
from vilma.sim.config import MUJOCO

CONNECT_TIMEOUT = 5.0
"""How long to wait for a scheduler to answer [s]."""
IN_FLIGHT = 256
"""Runs handed to the cluster ahead of the results (the rest wait here: the scheduler's memory stays bounded)."""
PNG_DPI = 100
"""Pixels per inch of a sweep's and a tune's plots."""
CHUNK = 8
"""Runs one Dask task makes at most: a run of a bundled course takes about 10 ms, and Dask's own cost a task is of
that order (``benchmarks/sweep_dask.py``), so short runs go in chunks."""
ENGINE = ("worker", "error")
"""The columns the engine adds after the scorecard."""
ROWS, PARQUET, CSV = "rows.jsonl", "results.parquet", "results.csv"
"""The files of a sweep's folder: a row a line as they come, then the table whole."""
BOXES = ("lateral_error_rms_m", "lateral_error_max_m", "speed_error_rms_mps", "speed_rise_time_90_s",
         "speed_overshoot_pct", "pose_error_rms_m")
"""Scorecard keys drawn as box plots, a box per group of runs (``box_<key>.png``), where any run has a value."""
SUMMARY = ("lateral_error_rms_m", "speed_error_rms_mps", "speed_rise_time_90_s", "wall_time_s")
"""Scorecard keys summarised per group (mean and standard deviation over its runs)."""


@contextlib.contextmanager
def connect(workers: int | None = None, scheduler: str | None = None) -> Iterator[Client]:
    """A Dask client of the scheduler at ``scheduler``, else of a new local cluster of ``workers`` processes (default:
    a core each), a thread each (runs hold the GIL).

    Raises:
        OSError: no scheduler answers at ``scheduler`` within :data:`CONNECT_TIMEOUT`, or it is no address.
    """
    if scheduler is not None:
        try:
            hello(scheduler, CONNECT_TIMEOUT)
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, ValueError, TypeError) as e:
            why = (f"no Dask scheduler answers there within {CONNECT_TIMEOUT:g} s; start one with `dask scheduler` "
                   "and give the address it prints" if isinstance(e, OSError) else
                   f"not a Dask scheduler's address ({e}); give one as `dask scheduler` prints it")
            raise OSError(f"--scheduler {scheduler}: {why} (tcp://host:8786)") from None
        with client:
            yield client
        return
    with LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        client.register_plugin(LocalWorker(logging.getLogger("distributed").getEffectiveLevel()))
        yield client


def hello(address: str, timeout: float) -> None:
    """Ask the server at ``address`` who it is, Dask's handshake and one request within ``timeout`` [s] in all: the
    Dask client's own start waits for ever on a port whose listener accepts and never answers.

    Raises:
        OSError: nothing answers in time, or what answers is no Dask scheduler (a worker, another server).
        ValueError, TypeError: ``address`` is no Dask address.
    """
    async def ask() -> object:
        comm = await connect_comm(address, timeout=timeout, **Security().get_connection_args("client"))  # (as Client)
        try:
            await comm.write({"op": "identity"})
            return await comm.read()
        finally:
            comm.abort()

    async def within() -> object:
        return await asyncio.wait_for(ask(), timeout)

    parse_address(address)  # (ValueError)
    with concurrent.futures.ThreadPoolExecutor(1) as pool:  # a loop of its own: the caller's may run one already
        try:
            who = pool.submit(asyncio.run, within()).result()
        except OSError as e:  # refused, closed, timed out
            raise OSError(f"no answer ({type(e).__name__})") from None
        except Exception:  # what it sent is no Dask message (read as a frame of exabytes, or no msgpack)
            raise ValueError("what answers there does not speak Dask's protocol") from None
    kind = who.get("type") if isinstance(who, dict) else None
    if kind != "Scheduler":
        raise ValueError(f"a Dask {kind} answers there, not a scheduler" if kind else "no Dask server answers there")


class LocalWorker(WorkerPlugin):
    """A local cluster's worker ignores SIGINT and logs at ``level``, the command's own Dask loggers' level.

    Ctrl-C in a terminal reaches the whole process group, the workers too: the command stops them itself, where
    each would print its traceback. A worker's process sets its loggers from Dask's configuration, not from the
    command's: it printed a failed heartbeat's traceback when the scheduler closed first.
    """

    name = "vilma-local-worker"

    def __init__(self, level: int) -> None:
        self.level = level

    def setup(self, worker) -> None:
        dask_logs(self.level)
        if threading.current_thread() is threading.main_thread():  # (a worker's loop runs in its process's)
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def dask_logs(level: int) -> None:
    """Set Dask's loggers and tornado's (each given its level by Dask's config) to ``level``."""
    for name in list(logging.root.manager.loggerDict):
        if name.partition(".")[0] in ("distributed", "tornado"):
            logging.getLogger(name).setLevel(level)


class Warm(WorkerPlugin):
    """Compiles (or loads from numba's cache) the closed loop once when a worker starts, not in its first run: a
    short drive of ``scenario``."""

    name = "vilma-warm"

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario

    def setup(self, worker) -> None:
        s = self.scenario
        with contextlib.suppress(Exception):  # a scenario that cannot run fails as its runs' rows, with the error
            run(dataclasses.replace(s, duration=min(s.duration, 1.0), expect={}))


def needs(scenarios: Iterable[Scenario]) -> tuple[str, ...]:
    """The extras (:data:`~vilma.core.extras.EXTRAS`) a worker needs beyond ``sweep`` to run ``scenarios``: ``roads``
    for a CommonRoad road, ``3d`` for the MuJoCo plant."""
    out = set()
    for s in scenarios:
        if s.road is not None:
            out.add("roads")
        if s.sim.model == MUJOCO:
            out.add("3d")
    return tuple(sorted(out))


def warm(client: Client, scenario: Scenario, extras: Sequence[str] = ()) -> None:
    """Check that every worker runs this vilma with ``extras``, then have each compile vilma's code once
    (:class:`Warm`), on ``scenario``.

    Raises:
        OSError: a worker cannot load vilma, runs another version of it or lacks one of ``extras``.
    """
    modules = {extra: EXTRAS[extra] for extra in extras}

    def facts() -> tuple[str, list[str]]:  # (defined here: sent by value, not as a name the worker's vilma defines)
        import importlib

        import vilma

        missing = []
        for extra, names in modules.items():
            try:
                for name in names:
                    importlib.import_module(name)
            except ImportError:
                missing.append(extra)
        return vilma.__version__, missing

    try:
        for address, (version, missing) in sorted(client.run(facts).items()):
            if version != vilma.__version__:
                raise OSError(f"the Dask worker {address} runs vilma {version}, this is vilma {vilma.__version__}; "
                              "install the same vilma[sweep] on every worker")
            if missing:
                raise OSError(f"the Dask worker {address} lacks the {' and '.join(missing)} extra these scenarios "
                              f"need: pip install 'vilma[sweep,{','.join(missing)}]' there")
        client.register_plugin(Warm(scenario))
    except OSError:
        raise
    except Exception as e:  # a worker without vilma
        raise OSError(f"the Dask workers cannot load vilma ({e}); install the same vilma[sweep] on every "
                      "worker") from None


def run_remote(scenario: Scenario, keep: str | None = None) -> dict[str, Any]:
    """One run on a worker: its scorecard, the worker, the error if it failed (every scorecard key then None, but
    ``wall_time_s``); with ``keep``, its files go into that folder."""
    t0 = time.perf_counter()
    try:
        r = record_run(scenario, Path(keep), started=t0) if keep else run(scenario, started=t0)
        row, error = r.metrics, None
    except Exception as e:  # any failure of one run is its row's, not the sweep's
        row = {**dict.fromkeys(SCORECARD_KEYS), "wall_time_s": time.perf_counter() - t0}
        error = str(e) or type(e).__name__
    return {**row, "worker": get_worker().address, "error": error}


def sweep_command(args: argparse.Namespace, console: Console) -> int:
    """``vilma sweep`` and ``vilma run ... --workers | --scheduler``: plan, run, print the summary; 1 if any failed."""
    # Dask's own logs (its workers coming and going, its sockets closing, a lost scheduler's traces): with -v only
    dask_logs(logging.CRITICAL if args.verbose < 1 else logging.getLogger().level)
    if args.command == "sweep":
        runs = read_sweep(args.sweep, args.yes)
    else:
        runs = plan_sets(args.scenarios, [*args.set, *([f"plant={args.plant}"] if args.plant else [])], args.yes)
    name = Path(args.sweep).stem if args.command == "sweep" else time.strftime("run-%Y%m%d-%H%M%S")
    out = Path(args.out) if args.out else Path("sweeps") / name
    console.print(f"vilma {args.command}: {len(runs)} runs on {args.scheduler or 'a local Dask cluster'}, "
                  f"table in {out}", highlight=False)
    table = sweep(runs, out, workers=args.workers, scheduler=args.scheduler, resume=args.resume,
                  keep_files=args.keep_files, plots=args.plots, console=console)
    console.print(summary_table(table))
    for error in table["error"].dropna().unique()[:10]:
        console.print(Text(f"FAIL: {error}"), style="red")
    return 1 if table["error"].notna().any() else 0


def sweep(runs: str | Path | Sequence[SweepRun], out: str | Path | None = None, *, workers: int | None = None,
          scheduler: str | None = None, resume: bool = False, keep_files: str | Path | None = None,
          plots: bool = True, yes: bool = False, console: Console | None = None) -> pd.DataFrame:
    """Run a sweep (a sweep file, or the runs of :func:`read_sweep` / :func:`plan_runs`) on Dask; returns its table, a
    row a run in plan order.

    ``out`` (default: none) keeps the rows as they come and the table, and with ``resume`` holds an earlier run of
    the sweep whose finished rows are kept (only the missing and the failed run again); ``keep_files`` is where each
    run writes its folder ``<keep_files>/<key>`` (a path the workers can write).

    Raises:
        SpecError: ``out`` holds an earlier sweep and ``resume`` is not given.
        KeyboardInterrupt: Ctrl-C; what finished is kept in ``out``, and the message says so.
        ConnectionError: the scheduler was lost (the same).
    """
    runs = read_sweep(runs, yes) if isinstance(runs, str | Path) else list(runs)
    console = console or Console(quiet=True)
    rows = Rows(Path(out) if out is not None else None, resume)
    todo = [r for r in runs if not rows.done(r.key)]
    if len(todo) < len(runs):
        console.print(f"resuming: {len(runs) - len(todo)} of {len(runs)} runs kept from {out}", highlight=False)
    try:
        if todo:
            _execute(todo, rows, workers, scheduler, keep_files, console)
    except (KeyboardInterrupt, ConnectionError) as e:
        rows.settle()
        why = f"{e}" if isinstance(e, ConnectionError) else "interrupted"
        kept = f": {rows.kept(runs)} of {len(runs)} runs kept in {out}; run it again with --resume for the rest"
        raise type(e)(why + (kept if out is not None else "")) from None
    finally:
        table = rows.table(runs)
        if out is not None and len(table):
            write_table(table, Path(out))
    if out is not None and plots and len(table):
        draw_boxes(table, Path(out))
    return table


def run_chunk(jobs: list[tuple[Scenario, str | None]]) -> list[dict[str, Any]]:
    """Runs one after another on a worker (:func:`run_remote` each): one Dask task for a chunk of runs."""
    return [run_remote(scenario, keep) for scenario, keep in jobs]


def chunk_size(runs: int, workers: int) -> int:
    """Runs a task makes: up to :data:`CHUNK`, fewer when the sweep is small, so that each worker gets four tasks."""
    return max(1, min(CHUNK, runs // (4 * max(workers, 1))))


def _execute(todo: list[SweepRun], rows: Rows, workers: int | None, scheduler: str | None,
             keep_files: str | Path | None, console: Console) -> None:
    """Run ``todo`` on the cluster in chunks (:func:`chunk_size`), :data:`IN_FLIGHT` runs at a time, each row into
    ``rows`` as its chunk comes."""
    with connect(workers, scheduler) as client, _progress(console) as bar:
        warm(client, todo[0].scenario, needs(r.scenario for r in todo))
        size = chunk_size(len(todo), len(client.scheduler_info()["workers"]))
        waiting = (todo[i:i + size] for i in range(0, len(todo), size))
        task = bar.add_task("sweep", total=len(todo), failed=0)
        by_key, done = {}, as_completed(with_results=True, raise_errors=False)  # results fetched as they come

        def submit(n: int) -> None:
            for chunk in itertools.islice(waiting, n):
                jobs = [(r.scenario, str(Path(keep_files) / r.key) if keep_files is not None else None)
                        for r in chunk]
                # a key of this submission's own: a task of the same key (another client's sweep on the scheduler,
                # a chunk that starts with the same run) would be taken for this one, its results for these runs
                f = client.submit(run_chunk, jobs, key=f"vilma-run-{len(chunk)}-{chunk[0].key}-{uuid.uuid4().hex}",
                                  pure=False, retries=0)
                by_key[f.key] = chunk
                done.add(f)

        submit(max(1, IN_FLIGHT // size))
        failed, i = 0, 0
        for f, results in done:
            chunk = by_key.pop(f.key)
            if f.status == "cancelled":
                raise ConnectionError(f"lost the Dask scheduler ({scheduler or 'of the local cluster'})")
            if f.status == "error":  # a chunk that killed its workers (Dask tried it on others first)
                results = [{**dict.fromkeys(SCORECARD_KEYS), "worker": None, "error": f"{results}"}] * len(chunk)
            f.release()
            for r, result in zip(chunk, results, strict=True):
                i += 1
                failed += result["error"] is not None
                rows.add({**r.row(), **result})
                if not console.is_terminal:  # a log or a pipe: a line a run instead of the bar
                    console.print(Text(f"[{i}/{len(todo)}] {r.label} "
                                       f"{' '.join(f'{k}={v}' for k, v in r.values)} seed {r.seed}: "
                                       f"{result['error'] or 'done'}"))
            bar.update(task, advance=len(chunk), failed=failed)
            submit(1)


class _Rate(ProgressColumn):
    """Runs a second."""

    def render(self, task) -> Text:
        return Text(f"{task.speed:.1f} runs/s" if task.speed else "- runs/s")


def _progress(console: Console) -> Progress:
    return Progress(TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(),
                    TextColumn("{task.completed}/{task.total} done, {task.fields[failed]} failed"), _Rate(),
                    TimeRemainingColumn(), console=console, transient=True, disable=not console.is_terminal)


class Rows:
    """The rows of a sweep by key, each appended to ``<out>/rows.jsonl`` (flushed) as it comes; a key already
    finished is not written again (a rescheduled run), a failed one is replaced by its rerun."""

    def __init__(self, out: Path | None, resume: bool) -> None:
        self.rows: dict[str, dict] = {}
        self.path = out / ROWS if out is not None else None
        self.file = None  # opened at the first row: a sweep that never starts leaves no file
        if self.path is not None and self.path.exists():
            if not resume:
                raise SpecError(f"{out}: holds an earlier sweep ({ROWS}); give --resume to finish it, or another "
                                "--out")
            self.rows = _read_rows(self.path)

    def done(self, key: str) -> bool:
        """Whether ``key`` has a row without an error."""
        return key in self.rows and self.rows[key]["error"] is None

    def add(self, row: dict) -> None:
        """Keep ``row`` (and write it) unless its run is already done."""
        if self.done(row["key"]):
            return
        self.rows[row["key"]] = row
        if self.path is not None:
            if self.file is None:
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self.file = self.path.open("a", encoding="utf-8")
            try:
                self.file.write(json.dumps(row) + "\n")
                self.file.flush()
            except OSError as e:  # a full disk: the rows so far stay (a line cut short is dropped on --resume)
                with contextlib.suppress(OSError):
                    self.file.close()
                self.file = None
                raise write_error(self.path, e) from None

    def settle(self) -> None:
        """After an interrupt: the rows as ``rows.jsonl`` holds them (Ctrl-C may land between a row's line and its
        entry here), so that the table, the count the message gives and a ``--resume`` agree."""
        if self.file is not None:
            self.file.close()
            self.file = None
            self.rows = _read_rows(self.path)

    def kept(self, runs: Sequence[SweepRun]) -> int:
        """How many of ``runs`` have a row."""
        return sum(r.key in self.rows for r in runs)

    def table(self, runs: Sequence[SweepRun]) -> pd.DataFrame:
        """The rows of ``runs`` that have one, in their order; columns: :data:`IDENTITY`, the swept values, the
        scorecard, :data:`ENGINE`."""
        if self.file is not None:
            self.file.close()
        rows = [self.rows[r.key] for r in runs if r.key in self.rows]
        swept = [k for k, _ in runs[0].values if k != "seed"] if runs else []  # the same keys in every run
        return pd.DataFrame(rows, columns=[*IDENTITY, *swept, *SCORECARD_KEYS, *ENGINE])


def _read_rows(path: Path) -> dict[str, dict]:
    """The rows of a ``rows.jsonl`` by key, the last of a key kept; a line cut short by a kill is dropped (and cut
    from the file, so that the next row starts a line)."""
    rows = {}
    with path.open("r+b") as f:
        lines = f.read().split(b"\n")
        if lines[-1]:  # the last row was cut short
            f.truncate(f.tell() - len(lines[-1]))
    for i, line in enumerate(lines[:-1], 1):
        try:
            row = json.loads(line)
        except ValueError:
            raise SpecError(f"{path}:{i}: not a row of a sweep; delete the line or use another --out") from None
        if not (row["key"] in rows and rows[row["key"]]["error"] is None):
            rows[row["key"]] = row
    return rows


def write_table(table: pd.DataFrame, out: Path, csv: str = CSV, parquet_name: str = PARQUET) -> None:
    """``table`` as ``csv`` and ``parquet_name`` in ``out`` (a sweep's ``results.*``), each whole or not at all."""
    with atomic_path(out / csv) as tmp:
        table.to_csv(tmp, index=False)
    parquet = table.copy()
    for c in parquet.columns:  # a column of words and numbers (a swept value) as text
        if pd.api.types.is_object_dtype(parquet[c]) and parquet[c].map(type).nunique() > 1 + parquet[c].isna().any():
            parquet[c] = parquet[c].map(lambda v: v if v is None else str(v))
    with atomic_path(out / parquet_name) as tmp:
        parquet.to_parquet(tmp, index=False)


def groups(table: pd.DataFrame) -> list[str]:
    """The columns a group of runs shares: the scenario and the swept values (not the seed)."""
    return [c for c in table.columns[: table.columns.get_loc("completed")] if c not in ("key", "seed")]


def draw_boxes(table: pd.DataFrame, out: Path) -> list[Path]:
    """A box plot a :data:`BOXES` key with values, a box per group of runs (:func:`groups`): PNGs in ``out``."""
    by = groups(table)
    names = table[by].astype(str).agg(" ".join, axis=1)
    written = []
    for key in BOXES:
        values = pd.to_numeric(table[key], errors="coerce")
        data = {n: v.dropna().to_numpy() for n, v in values.groupby(names, sort=False)}
        data = {n: v for n, v in data.items() if len(v)}
        if not data:
            continue
        fig = agg_figure(max(6.0, 0.6 * len(data) + 2), 5, dpi=PNG_DPI)
        ax = fig.add_subplot()
        ax.boxplot(list(data.values()), tick_labels=list(data))
        ax.set_ylabel(key)
        ax.set_title(f"{key} per group ({len(table)} runs)")
        ax.tick_params(axis="x", labelrotation=30)
        fig.tight_layout()
        written.append(write_png(fig, out / f"box_{key}.png", PNG_DPI))
    return written


def summary_table(table: pd.DataFrame) -> Table:
    """A row a group of runs (:func:`groups`): runs, failed, mean and standard deviation of the :data:`SUMMARY`
    keys."""
    by = groups(table)
    out = Table(title=f"vilma sweep: {len(table)} runs, {int(table['error'].notna().sum())} failed")
    for c in (*by, "runs", "failed"):
        out.add_column(Text(c))
    for k in SUMMARY:
        out.add_column(Text(k), justify="right")
    for name, g in table.groupby(by, sort=False, dropna=False):
        cells = [Text(str(v)) for v in (name if isinstance(name, tuple) else (name,))]
        stats = []
        for k in SUMMARY:
            v = pd.to_numeric(g[k], errors="coerce").dropna()
            stats.append("-" if v.empty else f"{v.mean():.4g} ± {v.std(ddof=0):.2g}")
        out.add_row(*cells, str(len(g)), str(int(g["error"].notna().sum())), *stats)
    return out
