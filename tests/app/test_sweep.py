"""Sweeps on Dask: a real ``dask scheduler`` and ``dask worker`` processes, the results table, resume, bad input."""

from __future__ import annotations

import contextlib
import errno
import json
import logging
import math
import os
import re
import signal
import socket
import sys
import threading
import time

import pandas as pd
import pytest
import yaml
from distributed import Client
from hypothesis import example, given, settings
from hypothesis import strategies as st

import vilma
from tests.conftest import Processes, free_port
from vilma.app import sweep, sweep_plan
from vilma.app.cli import main
from vilma.scenario.fields import SpecError, load_yaml
from vilma.scenario.runner import run
from vilma.scenario.scorecard import SCORECARD_KEYS, TIMING_KEYS
from vilma.scenario.spec import load_scenario

DASK = (sys.executable, "-m", "dask")
"""The ``dask`` command line."""
SHORT = "paper_fig11_speed_10"
"""A bundled scenario, cut to a few seconds in these sweeps."""


def _worker(processes: Processes, address: str, name: str):
    return processes.start(*DASK, "worker", address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                           "--no-dashboard", "--name", name)


@pytest.fixture(scope="module")
def scheduler():
    """The address of a real scheduler on 127.0.0.1 with two workers (``a``, ``b``), each its own process."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    with Processes() as processes:
        processes.start(*DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
        for name in "ab":
            _worker(processes, address, name)
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
        yield address


def _runs(speeds=(5, 10), seeds=(0, 1, 2), duration=3):
    return sweep_plan.plan_runs([SHORT], [("duration", [str(duration)]), ("task.speed", [str(s) for s in speeds])],
                           seeds=seeds)


def _same_as_alone(table: pd.DataFrame) -> None:
    """Every row's scorecard is the one of its run done alone in this process (the wall-clock keys aside)."""
    for row in table.to_dict("records"):
        alone = run(load_scenario(SHORT, {"duration": str(row["duration"]), "task.speed": str(row["task.speed"]),
                                          "seed": str(row["seed"])})).metrics
        for k in SCORECARD_KEYS:
            if k not in TIMING_KEYS:
                assert row[k] == alone[k] or (alone[k] is None and pd.isna(row[k])), (k, row[k], alone[k])


@pytest.mark.slow
def test_a_sweep_on_a_real_scheduler_is_each_run_alone(scheduler, tmp_path):
    runs = _runs(speeds=(5, 10), seeds=range(6))
    table = sweep.sweep(runs, tmp_path, scheduler=scheduler)
    assert list(table["key"]) == [r.key for r in runs] and table["error"].isna().all()
    def warm(dask_worker) -> bool:
        from vilma.scenario.lockstep import _loop

        return "vilma-warm" in dask_worker.plugins and bool(_loop.signatures)  # compiled before its first run

    with Client(scheduler) as client:
        workers = client.scheduler_info()["workers"]
        assert set(table["worker"]) == set(workers)  # both ran runs
        assert client.run(warm) == dict.fromkeys(workers, True)
    _same_as_alone(table)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / sweep.PARQUET), table, check_dtype=False)
    assert len(pd.read_csv(tmp_path / sweep.CSV)) == len(runs)
    assert len((tmp_path / sweep.ROWS).read_text().splitlines()) == len(runs)
    drawn = {k for k in sweep.BOXES if table[k].notna().any()}
    assert {p.name for p in tmp_path.glob("box_*.png")} == {f"box_{k}.png" for k in drawn} and drawn


def test_runs_go_in_chunks_that_leave_each_worker_four_tasks():
    assert sweep.chunk_size(200, 2) == sweep.CHUNK  # 200 runs: full chunks, 25 tasks for 2 workers
    assert sweep.chunk_size(24, 2) == 3  # 8 tasks, 4 a worker
    assert sweep.chunk_size(7, 2) == 1 and sweep.chunk_size(3, 0) == 1  # never empty, a scheduler without workers


@pytest.mark.slow
def test_a_chunked_sweep_is_each_run_alone_in_order(scheduler, monkeypatch):
    monkeypatch.setattr(sweep, "chunk_size", lambda runs, workers: 4)  # chunks of 4 and 2
    runs = _runs(speeds=(5,), seeds=range(6))
    table = sweep.sweep(runs, scheduler=scheduler)
    assert list(table["key"]) == [r.key for r in runs] and table["error"].isna().all()
    _same_as_alone(table)


@pytest.mark.slow
def test_two_sweeps_on_one_scheduler_get_each_their_own_runs(scheduler, tmp_path, monkeypatch):
    monkeypatch.setattr(sweep, "chunk_size", lambda runs, workers: 2)  # chunks that start alike and end apart:
    # (5, seed 2) with (10, seed 0) in one sweep, with (11, seed 0) in the other; the same at 15 (two such chunks:
    # the first sweep holds at least one of them when it stops at its first row)
    reached, release = threading.Event(), threading.Event()
    add = sweep.Rows.add

    def add_and_hold(self, row):
        add(self, row)
        if self.path is not None:  # the first sweep (the one with a folder) keeps its tasks on the scheduler
            reached.set()
            assert release.wait(120)

    monkeypatch.setattr(sweep.Rows, "add", add_and_hold)
    first = threading.Thread(target=sweep.sweep, args=(_runs(speeds=(5, 10, 15, 20)), tmp_path), kwargs={
        "scheduler": scheduler, "plots": False})
    first.start()
    try:
        assert reached.wait(120)
        table = sweep.sweep(_runs(speeds=(5, 11, 15, 21)), scheduler=scheduler)
    finally:
        release.set()
        first.join(120)
    assert table["error"].isna().all()
    _same_as_alone(table)


@pytest.mark.slow
def test_a_killed_worker_loses_no_run_and_repeats_none(scheduler, tmp_path, monkeypatch, processes):
    victim = _worker(processes, scheduler, "victim")
    reached, killed = threading.Event(), threading.Event()
    add = sweep.Rows.add

    def add_then_wait(self, row):
        add(self, row)
        if len(self.rows) == 3:  # the sweep is under way: the victim goes now, with runs queued on it
            reached.set()
            assert killed.wait(60)

    monkeypatch.setattr(sweep.Rows, "add", add_then_wait)
    runs = _runs(speeds=(5, 7, 10, 12), seeds=range(8), duration=10)
    out: list[pd.DataFrame] = []
    t = threading.Thread(target=lambda: out.append(sweep.sweep(runs, tmp_path, scheduler=scheduler)))
    with Client(scheduler) as client:
        client.wait_for_workers(3, timeout=120)
        (address,) = (a for a, w in client.scheduler_info()["workers"].items() if w["name"] == "victim")
        t.start()
        assert reached.wait(120)
        deadline = time.monotonic() + 60  # it dies with runs in hand: it may be between two at this instant
        while not client.processing([address])[address]:
            assert time.monotonic() < deadline, "the victim holds no run to lose"
            time.sleep(0.01)
    victim.send_signal(signal.SIGKILL)
    victim.wait(60)
    killed.set()
    t.join(300)
    (table,) = out
    assert list(table["key"]) == [r.key for r in runs] and table["error"].isna().all()
    keys = [json.loads(line)["key"] for line in (tmp_path / sweep.ROWS).read_text().splitlines()]
    assert sorted(keys) == sorted(r.key for r in runs)  # each once
    _same_as_alone(table)


@pytest.mark.slow
def test_an_interrupted_sweep_keeps_its_rows_and_resume_runs_the_rest(scheduler, tmp_path, monkeypatch):
    runs = _runs(seeds=range(4))
    add = sweep.Rows.add

    def add_then_ctrl_c(self, row):
        add(self, row)
        if len(self.rows) == 3:
            raise KeyboardInterrupt

    monkeypatch.setattr(sweep.Rows, "add", add_then_ctrl_c)
    kept_in = rf"3 of {len(runs)} runs kept in {re.escape(str(tmp_path))}; .* --resume"
    with pytest.raises(KeyboardInterrupt, match=kept_in):
        sweep.sweep(runs, tmp_path, scheduler=scheduler)
    kept = pd.read_parquet(tmp_path / sweep.PARQUET)
    assert len(kept) == 3
    monkeypatch.setattr(sweep.Rows, "add", add)
    with pytest.raises(ValueError, match=r"holds an earlier sweep .* give --resume"):
        sweep.sweep(runs, tmp_path, scheduler=scheduler)
    table = sweep.sweep(runs, tmp_path, scheduler=scheduler, resume=True)
    assert list(table["key"]) == [r.key for r in runs]
    again = table.set_index("key").loc[kept["key"]]
    assert list(again["wall_time_s"]) == list(kept["wall_time_s"])  # kept, not run again
    assert len((tmp_path / sweep.ROWS).read_text().splitlines()) == len(runs)
    _same_as_alone(table)


@pytest.mark.slow
def test_ctrl_c_keeps_the_finished_runs_and_resume_runs_the_rest(scheduler, tmp_path, processes):
    n = 80  # runs: enough that the workers cannot finish them all while Ctrl-C reaches the command
    (tmp_path / "s.yaml").write_text(f"scenarios: {SHORT}\ngrid: {{duration: 10, task.speed: [5, 10]}}\n"
                                     f"seeds: {n // 2}\n")
    argv = ("sweep", "s.yaml", "--scheduler", scheduler, "--out", "out")
    p = processes.vilma(*argv, cwd=tmp_path)
    for line in p.stdout:
        if line.startswith(f"[3/{n}]"):
            p.send_signal(signal.SIGINT)
            break
    rest = p.communicate(timeout=120)[0]
    assert p.returncode == 130, rest
    kept = pd.read_parquet(tmp_path / "out" / sweep.PARQUET)
    assert 3 <= len(kept) < n and f"vilma sweep: interrupted: {len(kept)} of {n} runs kept in out; run it again " \
                                  "with --resume for the rest" in rest
    again = processes.vilma(*argv, "--resume", cwd=tmp_path)
    out = again.communicate(timeout=300)[0]
    assert again.returncode == 0, out
    assert f"resuming: {len(kept)} of {n} runs kept" in out and f"[{n - len(kept)}/{n - len(kept)}]" in out
    table = pd.read_parquet(tmp_path / "out" / sweep.PARQUET)
    assert sorted(table["key"]) == sorted(r.key for r in sweep_plan.read_sweep(tmp_path / "s.yaml"))
    pd.testing.assert_frame_equal(table.set_index("key").loc[kept["key"]].reset_index(), kept)  # kept as they were


@pytest.mark.slow
def test_ctrl_c_in_a_terminal_stops_a_local_cluster_with_one_line(tmp_path, processes):
    """A terminal's Ctrl-C reaches the process group, the command's local workers too: one line, no worker's
    traceback."""
    n = 200
    (tmp_path / "s.yaml").write_text(f"scenarios: {SHORT}\ngrid: {{duration: 10}}\nseeds: {n}\n")
    p = processes.vilma("sweep", "s.yaml", "--workers", "1", "--out", "out", cwd=tmp_path, start_new_session=True)
    for line in p.stdout:
        if line.startswith(f"[3/{n}]"):
            os.killpg(p.pid, signal.SIGINT)
            break
    rest = p.communicate(timeout=120)[0]
    assert p.returncode == 130, rest
    kept = len(pd.read_parquet(tmp_path / "out" / sweep.PARQUET))
    said = [line for line in rest.splitlines() if not line.startswith("[")]
    assert said == [f"vilma sweep: interrupted: {kept} of {n} runs kept in out; run it again with --resume for the "
                    "rest"], rest


@pytest.mark.slow
def test_a_local_clusters_workers_log_at_the_commands_level_and_ignore_ctrl_c():
    """A worker's process sets its loggers from Dask's configuration: without the command's level it printed a failed
    heartbeat's traceback after Ctrl-C, when the scheduler closed first."""
    def state() -> tuple[int, object]:  # a local function, sent by value: the worker must not import the tests'
        worker = logging.getLogger("distributed.worker")  # conftest, which sets SIGINT's handler
        return worker.getEffectiveLevel(), signal.getsignal(signal.SIGINT)

    loggers = [logging.getLogger(name) for name in list(logging.root.manager.loggerDict)
               if name.partition(".")[0] in ("distributed", "tornado")]
    before = [logger.level for logger in loggers]
    try:
        sweep.dask_logs(logging.CRITICAL)
        with sweep.connect(workers=1) as client:
            states = client.run(state)
    finally:
        for logger, level in zip(loggers, before, strict=True):
            logger.setLevel(level)
    assert list(states.values()) == [(logging.CRITICAL, signal.SIG_IGN)]


@pytest.mark.slow
def test_a_lost_scheduler_keeps_the_finished_runs_and_exits_2(tmp_path, processes):
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    lost = processes.start(*DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
    _worker(processes, address, "w")
    (tmp_path / "s.yaml").write_text(f"scenarios: {SHORT}\ngrid: {{duration: 10}}\nseeds: 100\n")
    p = processes.vilma("sweep", "s.yaml", "--scheduler", address, "--out", "out", cwd=tmp_path)
    for line in p.stdout:
        if line.startswith("[3/100]"):
            lost.kill()
            break
    rest = p.communicate(timeout=120)[0]
    assert p.returncode == 1, rest  # a failure, not a mistake in the command
    kept = pd.read_parquet(tmp_path / "out" / sweep.PARQUET)
    assert 3 <= len(kept) < 100 and kept["error"].isna().all()
    (error,) = [line for line in rest.splitlines() if not line.startswith("[")]
    assert error == (f"vilma sweep: error: lost the Dask scheduler ({address}): {len(kept)} of 100 runs kept in out; "
                     "run it again with --resume for the rest")


@pytest.mark.slow
def test_the_cluster_holds_at_most_in_flight_runs(scheduler, monkeypatch):
    def held(dask_scheduler) -> int:
        return sum(int(str(k).split("-")[2]) for k in dask_scheduler.tasks if str(k).startswith("vilma-run-"))

    counts = []
    add = sweep.Rows.add

    def add_and_count(self, row):
        add(self, row)
        counts.append(client.run_on_scheduler(held))

    monkeypatch.setattr(sweep, "IN_FLIGHT", 2)
    monkeypatch.setattr(sweep.Rows, "add", add_and_count)
    with Client(scheduler) as client:
        table = sweep.sweep(_runs(seeds=range(4)), scheduler=scheduler)
    assert len(table) == 8 and table["error"].isna().all() and len(counts) == 8 and max(counts) <= 2


@pytest.mark.slow
def test_workers_without_vilma_are_one_line_and_exit_2(tmp_path, processes, capsys):
    (tmp_path / "vilma").mkdir()  # what the workers import as vilma (their folder comes first in their path)
    (tmp_path / "vilma" / "__init__.py").write_text("raise ImportError('no vilma here')\n")
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes.start(*DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
    processes.start(*DASK, "worker", address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                    "--no-dashboard", cwd=tmp_path)
    with Client(address, timeout=60) as client:
        client.wait_for_workers(1, timeout=120)
    assert main(["run", SHORT, "--set", "duration=3", "--scheduler", address, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "vilma run: error: the Dask workers cannot load vilma (" in err and "install the same vilma[sweep]" in err
    assert err.count("\n") == 1 and not (tmp_path / "out").exists()


BLOCK_ROADS = """import sys
class Block:  # commonroad-io not installed, as far as this worker knows
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in ("commonroad", "commonroad_route_planner", "commonroad_dc"):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
sys.meta_path.insert(0, Block())
from distributed.cli.dask_worker import main
main()
"""
"""A ``dask worker`` without the roads extra."""


@pytest.mark.slow
@pytest.mark.parametrize("other", ["version", "roads"])
def test_a_worker_of_another_vilma_or_without_an_extra_is_one_line_and_exit_2(other, tmp_path, processes, capsys):
    here = tmp_path / "worker"
    here.mkdir()
    if other == "version":  # this vilma's modules, under another version (the worker's folder comes first)
        (here / "vilma").mkdir()
        (here / "vilma" / "__init__.py").write_text(f"__path__.append({str(vilma.__path__[0])!r})\n"
                                                    "__version__ = 'another'\n")
        worker = (*DASK, "worker")
    else:
        (here / "no_roads.py").write_text(BLOCK_ROADS)
        worker = (sys.executable, str(here / "no_roads.py"))
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes.start(*DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
    processes.start(*worker, address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1", "--no-dashboard",
                    cwd=here)
    with Client(address, timeout=60) as client:
        client.wait_for_workers(1, timeout=120)
        (worker_address,) = client.scheduler_info()["workers"]
    scenario = "commonroad_tutorial" if other == "roads" else SHORT
    assert main(["run", scenario, "--set", "duration=3", "--scheduler", address, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    expected = (f"the Dask worker {worker_address} runs vilma another, this is vilma {vilma.__version__}; install "
                "the same vilma[sweep] on every worker" if other == "version" else
                f"the Dask worker {worker_address} lacks the roads extra these scenarios need: "
                "pip install 'vilma[sweep,roads]' there")
    assert expected in err and err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_the_extras_a_worker_needs_are_those_of_the_scenarios():
    assert sweep.needs([load_scenario(SHORT)]) == ()
    assert sweep.needs([load_scenario(SHORT), load_scenario("commonroad_tutorial")]) == ("roads",)
    assert sweep.needs([load_scenario(SHORT, {"plant": "mujoco"})]) == ("3d",)


@pytest.mark.slow
def test_a_run_that_fails_is_a_row_with_its_error(scheduler, tmp_path):
    blocked = tmp_path / "a_file"
    blocked.write_text("not a folder")
    table = sweep.sweep(_runs(speeds=(5,), seeds=(0,)), keep_files=blocked, scheduler=scheduler)
    (error,) = table["error"]
    assert str(blocked) in error and table["completed"].isna().all()


@pytest.mark.slow
def test_keep_files_writes_each_runs_folder(scheduler, tmp_path):
    table = sweep.sweep(_runs(speeds=(5,), seeds=(0, 1)), keep_files=tmp_path, scheduler=scheduler)
    for row in table.to_dict("records"):
        metrics = json.loads((tmp_path / row["key"] / "metrics.json").read_text())
        assert metrics["speed_error_rms_mps"] == row["speed_error_rms_mps"]


@pytest.mark.slow
def test_vilma_run_on_a_local_cluster(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert main(["run", SHORT, "--set", "duration=3", "--set", "task.speed=5,10", "--workers", "1", "--out",
                 str(out)]) == 0
    table = pd.read_csv(out / sweep.CSV)
    assert list(table["task.speed"]) == [5, 10] and table["error"].isna().all()
    assert "vilma sweep: 2 runs, 0 failed" in capsys.readouterr().out
    assert not list(out.glob("*.png"))  # `vilma run` draws plots on request (--plots), its box plots too


def test_a_sweep_file_names_scenarios_grid_samples_and_seeds(tmp_path):
    (tmp_path / "more").mkdir()
    (tmp_path / "more" / "slow.yaml").write_text("task: {speed: 3}\n")
    f = tmp_path / "s.yaml"
    f.write_text(f"scenarios: [{SHORT}, more]\ngrid: {{duration: 3, task.speed: [4, 6]}}\n"
                 "samples: {count: 2, seed: 7, values: {initial.speed: {uniform: [0, 1]}}}\nseeds: 3\n")
    runs = sweep_plan.read_sweep(f)
    assert len(runs) == 2 * 2 * 2 * 3 and len({r.key for r in runs}) == len(runs)
    assert {r.label for r in runs} == {SHORT, str(tmp_path / "more" / "slow.yaml")}
    assert {r.seed for r in runs} == {r.scenario.sim.seed for r in runs} == {0, 1, 2}
    assert {r.scenario.task.speed for r in runs} == {4, 6} and {r.scenario.duration for r in runs} == {3}
    assert runs == sweep_plan.read_sweep(f)  # the same draws, the same keys


def test_a_run_asked_for_twice_runs_once():
    runs = sweep_plan.plan_runs([SHORT, SHORT], [("task.speed", ["5", "5", "6"])], seeds=[0])
    assert [dict(r.values)["task.speed"] for r in runs] == ["5", "6"] and len({r.key for r in runs}) == 2


@pytest.mark.parametrize(("text", "message"), [
    ("scenarios: x\ngrdi: {}\n", "s.yaml:2: grdi: unknown key; did you mean 'grid'?"),
    ("scenarios: [nope]\n", "s.yaml: nope: no such file, nor a bundled scenario"),
    (f"scenarios: {SHORT}\nseeds: 0\n", "s.yaml:2: seeds: expected a count of seeds >= 1"),
    (f"scenarios: {SHORT}\nsamples: {{count: 2, values: {{duration: {{uniform: [3, 1]}}}}}}\n",
     "s.yaml:2: samples.values.duration.uniform: expected [low, high], low < high, finite numbers at most 1.8e308 "
     "apart, got [3, 1]"),
    *((f"scenarios: {SHORT}\ngrid: {{duration: 3}}\nsamples: {{count: 2, seed: 1, values: {{kp: {{{d}}}}}}}\n",
       f"s.yaml:3: samples.values.kp.{d.partition(':')[0]}: expected [") for d in (
        "uniform: [0.5, .inf]", "uniform: [-1e308, 1e308]", "loguniform: [1, .inf]", "normal: [1, .inf]",
        "normal: [.nan, 1]", "choice: [1, .nan]", "uniform: [0, 1" + "0" * 400 + "]")),
    # a draw past the largest float: half the draws of a normal about it (all 64 within: 2**-64)
    (f"scenarios: {SHORT}\nsamples: {{count: 64, values: {{kp: {{normal: [1.7976931348623157e+308, 1.0e+308]}}}}}}\n",
     "s.yaml:2: samples.values.kp: drew inf, not a finite number; narrow the distribution"),
    (f"scenarios: {SHORT}\nsamples: {{count: 2, values: {{duration: {{gamma: [3, 1]}}}}}}\n",
     "s.yaml:2: samples.values.duration.gamma: unknown distribution (known: uniform, normal, loguniform, choice)"),
    (f"scenarios: {SHORT}\ngrid: {{task.speed: [5, abc]}}\n",
     's.yaml:2: --set task.speed="abc": task.speed: expected a number'),
    (f"scenarios: {SHORT}\ngrid:\n  duration: 3\n  task.speed:\n    - 5\n    - -3\n",
     "s.yaml:6: --set task.speed=-3: task.speed: speed must be > 0 m/s, got -3.0"),
    (f"scenarios: {SHORT}\ngrid: {{duration: 3}}\nsamples:\n  count: 2\n  values:\n    duration: {{choice: [-1]}}\n",
     "s.yaml:6: --set duration=-1: duration: "),
    (f"scenarios: [{SHORT}]\ngrid: {{seed: 3}}\nseeds: 2\n", "s.yaml:3: seeds: seed is in the grid too"),
    (f"scenarios: {SHORT}\ngrid: {{a: {list(range(1000))}, b: {list(range(1000))}, c: {list(range(1000))}}}\n",
     f"1e+09 runs, more than {sweep_plan.MAX_RUNS} in one sweep; split it"),
    (f"scenarios: {SHORT}\nseeds: 20000\n", f"20000 runs, more than {sweep_plan.CONFIRM_RUNS}; give --yes"),
])
def test_bad_sweep_files_are_one_line_and_exit_2_before_any_run(text, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "s.yaml").write_text(text)
    assert main(["sweep", "s.yaml"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and not (tmp_path / "sweeps").exists()


def test_an_unreachable_scheduler_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    address = f"tcp://127.0.0.1:{free_port()}"
    assert main(["run", SHORT, "--set", "duration=3", "--scheduler", address]) == 2
    err = capsys.readouterr().err
    assert f"--scheduler {address}: no Dask scheduler answers there within {sweep.CONNECT_TIMEOUT:g} s" in err
    assert err.count("\n") == 1 and not (tmp_path / "sweeps").exists()


@pytest.fixture
def listener():
    """A plain TCP listener on 127.0.0.1 that is no Dask server: ``listener(reply)`` starts one whose connections
    read what comes and get ``reply`` (``None``: nothing, the connection held open); yields its address."""
    started = []

    def start(reply: bytes | None) -> str:
        server = socket.create_server(("127.0.0.1", 0))
        held: list[socket.socket] = []

        def serve() -> None:
            with contextlib.suppress(OSError):  # (the server closed at the end)
                while True:
                    conn, _ = server.accept()
                    held.append(conn)
                    if reply is not None:
                        conn.recv(1024)
                        conn.sendall(reply)

        threading.Thread(target=serve, daemon=True).start()
        started.append((server, held))
        return f"tcp://127.0.0.1:{server.getsockname()[1]}"

    yield start
    for server, held in started:
        server.close()
        for conn in held:
            conn.close()


@pytest.mark.parametrize(("reply", "message"), [
    (None, "no Dask scheduler answers there within 0.5 s"),
    (b"HTTP/1.0 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 8,
     "not a Dask scheduler's address (what answers there does not speak Dask's protocol)"),
])
def test_a_port_that_is_no_dask_scheduler_is_one_line_and_exit_2_in_time(reply, message, listener, tmp_path,
                                                                          capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sweep, "CONNECT_TIMEOUT", 0.5)
    address = listener(reply)
    done: list[int] = []  # (Dask's client alone waits for ever on a listener that never answers)
    t = threading.Thread(target=lambda: done.append(main(["run", SHORT, "--set", "duration=3", "--scheduler",
                                                          address])), daemon=True)
    t.start()
    t.join(120)
    assert done == [2]
    err = capsys.readouterr().err
    assert f"--scheduler {address}: {message}" in err and err.count("\n") == 1 and not (tmp_path / "sweeps").exists()


@pytest.mark.slow
def test_a_workers_address_is_no_schedulers(scheduler, capsys):
    with Client(scheduler) as client:
        address = next(iter(client.scheduler_info()["workers"]))
    assert main(["run", SHORT, "--set", "duration=3", "--scheduler", address]) == 2
    assert "a Dask Worker answers there, not a scheduler" in capsys.readouterr().err


@pytest.mark.parametrize("address", ["tcp://127.0.0.1:99999", "http://x", "garbage"])
def test_a_malformed_scheduler_address_is_an_argparse_error_before_any_connection(address, capsys):
    with pytest.raises(SystemExit) as e:
        main(["sweep", "s.yaml", "--scheduler", address])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "vilma sweep: error: argument --scheduler: " in err and "within" not in err


@pytest.mark.parametrize(("args", "message"), [
    (["--workers", "2", "--cars", "3"], "--workers and --scheduler run on Dask as fast as they can: drop --cars"),
    (["--scheduler", "tcp://127.0.0.1:1", "--realtime", "1"], "drop --cars, --realtime and --foxglove"),
    (["--resume"], "--resume, --keep-files and --yes are for runs on Dask: add --workers N or --scheduler"),
    (["--keep-files", "x"], "--resume, --keep-files and --yes are for runs on Dask"),
])
def test_engine_options_out_of_place_are_one_line_and_exit_2(args, message, capsys):
    assert main(["run", SHORT, *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


@settings(max_examples=50, deadline=None)
@given(lo=st.floats(1e-3, 1e3), span=st.floats(1.01, 1e3), count=st.integers(1, 20), seed=st.integers(0, 2**32))
def test_samples_stay_within_their_distributions(lo, span, count, seed):
    hi = lo * span
    data, src = load_yaml(f"count: {count}\nseed: {seed}\nvalues: {{u: {{uniform: [{lo!r}, {hi!r}]}}, "
                          f"l: {{loguniform: [{lo!r}, {hi!r}]}}, c: {{choice: [a, 3, true]}}}}\n", "s.yaml")
    draws = sweep_plan._samples(data, src)
    assert len(draws) == count
    for d in draws:
        v = {k: json.loads(x) for k, x in d}
        assert lo <= v["u"] <= hi and lo * (1 - 1e-12) <= v["l"] <= hi * (1 + 1e-12) and v["c"] in ("a", 3, True)


@settings(max_examples=200, deadline=None)
@given(name=st.sampled_from(["uniform", "normal", "loguniform"]), a=st.floats(), b=st.floats())
@example(name="normal", a=0.0, b=-0.0)  # a std numpy refuses by its sign bit
def test_distribution_parameters_are_drawn_finite_or_refused_with_their_line(name, a, b):
    args = yaml.safe_dump([a, b], default_flow_style=True).strip()
    data, src = load_yaml(f"samples:\n  count: 3\n  values:\n    k: {{{name}: {args}}}\n", "s.yaml")
    # what numpy's generator draws from: finite numbers, uniform's high - low within a float too
    fine = math.isfinite(a) and math.isfinite(b) and {"uniform": a < b and math.isfinite(b - a),
                                                      "normal": math.copysign(1.0, b) > 0,  # -0.0: not
                                                      "loguniform": 0 < a < b}[name]
    try:
        draws = sweep_plan._samples(data["samples"], src)
    except SpecError as e:
        assert str(e).startswith("s.yaml:4: samples.values.k") and "\n" not in str(e)
        assert not fine or "drew inf" in str(e) or "drew -inf" in str(e)  # a normal past the largest float
        return
    assert fine and all(math.isfinite(json.loads(x)) for d in draws for _, x in d)


def test_rows_cut_short_by_a_kill_are_dropped_and_done_runs_not_written_twice(tmp_path):
    rows = sweep.Rows(tmp_path, resume=False)
    done = {"key": "k1", "error": None, "x": 1.5}
    rows.add(done)
    rows.add({**done, "x": 2.0})  # a run Dask rescheduled after its worker died
    rows.add({"key": "k2", "error": "boom"})
    rows.file.close()
    with (tmp_path / sweep.ROWS).open("a") as f:
        f.write('{"key": "k3", "err')  # the process was killed mid-line
    again = sweep.Rows(tmp_path, resume=True)
    assert again.rows == {"k1": done, "k2": {"key": "k2", "error": "boom"}}
    assert again.done("k1") and not again.done("k2") and not again.done("k3")
    again.add({"key": "k2", "error": None})  # a failed run, run again
    again.file.close()
    lines = [json.loads(line) for line in (tmp_path / sweep.ROWS).read_text().splitlines()]
    assert [r["key"] for r in lines] == ["k1", "k2", "k2"] and sweep.Rows(tmp_path, True).done("k2")


def test_after_an_interrupt_the_rows_are_what_the_file_holds(tmp_path):
    rows = sweep.Rows(tmp_path, resume=False)
    done = {"key": "k1", "error": None}
    rows.add(done)
    rows.rows["k2"] = {"key": "k2", "error": None}  # Ctrl-C after its entry, before its line
    rows.file.write('{"key": "k3", "err')  # Ctrl-C mid-line
    rows.settle()
    assert rows.rows == {"k1": done} and rows.file is None
    assert (tmp_path / sweep.ROWS).read_text() == json.dumps(done) + "\n"  # what --resume reads


def test_a_full_disk_names_the_rows_file_and_keeps_its_rows(tmp_path):
    rows = sweep.Rows(tmp_path, resume=False)
    done = {"key": "k1", "error": None}
    rows.add(done)
    real = rows.file

    class Full:  # a file on a full disk: its write stays in its buffer, its flush and close fail
        def write(self, text):
            return len(text)

        def flush(self):
            raise OSError(errno.ENOSPC, "No space left on device")

        def close(self):
            real.close()
            self.flush()

    rows.file = Full()
    with pytest.raises(OSError, match=re.escape(str(tmp_path / sweep.ROWS))) as e:
        rows.add({"key": "k2", "error": None})
    assert e.value.errno == errno.ENOSPC and real.closed
    assert list(rows.table(sweep_plan.plan_runs([SHORT], [], seeds=[0]))["key"]) == []  # no error: the table is made
    assert sweep.Rows(tmp_path, True).rows == {"k1": done}  # what --resume reads


def test_run_keys_name_scenario_values_and_seed():
    key = sweep_plan.run_key
    a = key(SHORT, [("task.speed", "5")], 0)
    assert a == key(SHORT, [("task.speed", "5")], 0) and len(a) == 16
    assert len({a, key(SHORT, [("task.speed", "6")], 0), key(SHORT, [("task.speed", "5")], 1),
                key("other", [("task.speed", "5")], 0)}) == 4
    assert int(a, 16) >= 0  # hex digits: a folder name on any file system
