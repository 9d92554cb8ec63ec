"""``vilma serve``: commands run on a warm server as in their own process, with their streams, status and Ctrl-C;
bad requests refused while it keeps serving; a changed vilma stops it."""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import os
import queue
import select
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import VILMA, Processes
from vilma.app import serve
from vilma.scenario.scorecard import TIMING_KEYS

SCENARIO = "pi_ff_speed_5"
"""A short drive in the compiled loop: the server's warm-up and the runs served."""


class Server:
    """A ``vilma serve`` process at ``socket`` and the lines it prints."""

    def __init__(self, processes: Processes, socket_path: Path, *options: str) -> None:
        self.socket = socket_path
        self.proc = processes.vilma("serve", "--socket", str(socket_path), *options, stdin=subprocess.DEVNULL)
        self.lines: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._pump, daemon=True).start()
        self.expect("Ctrl-C ends", timeout=300)  # a first run on a fresh install compiles its warm-up

    def _pump(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put("")  # its end

    def expect(self, text: str, timeout: float = 60) -> str:
        """The next line it prints holding ``text`` (the lines before it skipped)."""
        deadline, seen = time.monotonic() + timeout, []
        while text not in (line := self.lines.get(timeout=max(0.0, deadline - time.monotonic()))):
            assert line, f"the server ended before printing {text!r}: {''.join(seen)}"
            seen.append(line)
        return line

    def client(self, *args: str, cwd: Path, **kw) -> subprocess.CompletedProcess:
        """``vilma args`` run to its end as a client of this server."""
        env = {**os.environ, "VILMA_SERVE": str(self.socket)}
        return subprocess.run([*VILMA, *args], cwd=cwd, env=env, capture_output=True, text=True, timeout=120,
                              stdin=subprocess.DEVNULL, **kw)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with Processes() as processes:
        yield Server(processes, tmp_path_factory.mktemp("serve") / "s.sock", "--warm-up", SCENARIO)
        processes.started[0].send_signal(signal.SIGTERM)
        assert processes.started[0].wait(timeout=30) == 0


def metrics(folder: Path) -> dict:
    return {k: v for k, v in json.loads((folder / "metrics.json").read_text()).items() if k not in TIMING_KEYS}


def test_a_served_run_writes_what_its_own_process_writes(server, tmp_path):
    served = server.client("run", SCENARIO, "--out", "served", "--no-plots", "-q", cwd=tmp_path)
    assert served.returncode == 0, served.stderr
    assert f"vilma run {SCENARIO} --out served" in server.expect("vilma run")  # it ran on the server
    alone = subprocess.run([*VILMA, "run", SCENARIO, "--out", "alone", "--no-plots", "-q"], cwd=tmp_path,
                           capture_output=True, text=True, timeout=300, stdin=subprocess.DEVNULL)
    assert alone.returncode == 0, alone.stderr
    a, b = tmp_path / "served", tmp_path / "alone"  # relative --out: in the client's working directory
    assert metrics(a) == metrics(b)
    assert (a / "timeseries.csv").read_bytes() == (b / "timeseries.csv").read_bytes()
    assert (a / "run.mcap").stat().st_size > 0


def test_a_served_command_s_error_and_status_reach_its_client(server, tmp_path):
    bad = server.client("run", "no_such_scenario", cwd=tmp_path)
    assert bad.returncode == 2
    assert bad.stderr.startswith("vilma run: error: no_such_scenario: no such file") and bad.stderr.count("\n") == 1
    usage = server.client("run", cwd=tmp_path)  # argparse's own exit
    assert usage.returncode == 2 and "the following arguments are required: SCENARIO" in usage.stderr
    listed = server.client("scenarios", cwd=tmp_path)
    assert listed.returncode == 0 and f"{SCENARIO}: " in listed.stdout


@pytest.mark.parametrize(("signum", "status"), [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_a_signal_to_the_client_stops_the_served_run_with_its_status(server, tmp_path, signum, status):
    """Ctrl-C, SIGTERM and SIGHUP as in the command's own process: its line, and the status a shell gives a command
    that signal ended."""
    env = {**os.environ, "VILMA_SERVE": str(server.socket)}
    with Processes() as processes:
        client = processes.vilma("run", SCENARIO, "--realtime", "1", "--out", "paced", "--no-plots", "--no-record",
                                 cwd=tmp_path, env=env, stdin=subprocess.DEVNULL)
        server.expect("--realtime 1")
        deadline = time.monotonic() + 60
        while not list(tmp_path.glob("paced/timeseries.csv*")) and time.monotonic() < deadline:
            time.sleep(0.05)  # the run has started
        client.send_signal(signum)
        out, _ = client.communicate(timeout=60)
    assert client.returncode == status
    assert out.startswith("vilma run: interrupted at t=") and out.count("\n") == 1, out
    assert not (tmp_path / "paced" / "metrics.json").exists()  # not a whole run


def _ask(path: Path, data: bytes, fds: list[int]) -> dict:
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.connect(str(path))
        with contextlib.suppress(BrokenPipeError):  # (a server that answers before it reads: a busy one)
            socket.send_fds(s, [data], fds)
        return json.loads(s.makefile("rb").readline())


def test_bad_requests_are_refused_and_the_server_keeps_serving(server, tmp_path):
    cwd = str(tmp_path)
    ok = {"argv": ["scenarios"], "cwd": cwd, "env": {}}
    with open(os.devnull) as null:
        streams = [null.fileno()] * 3
        for data, fds in [(b"garbage\n", streams), ((json.dumps(ok) + "\n").encode(), []),
                          (json.dumps({**ok, "argv": ["gui"]}).encode() + b"\n", streams),
                          (json.dumps({**ok, "cwd": str(tmp_path / "gone")}).encode() + b"\n", streams),
                          (b"[" * (serve.MAX_REQUEST + 10), streams)]:
            answer = _ask(server.socket, data, fds)
            assert answer["error"].startswith("bad request: ")
            assert "refused a request" in server.expect("vilma serve: ")
    assert server.client("scenarios", cwd=tmp_path).returncode == 0


@given(st.binary(max_size=300) | st.recursive(st.none() | st.booleans() | st.integers() | st.text(max_size=8),
                                              lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=8),
                                                                                                     c, max_size=4))
       .map(lambda v: (json.dumps(v) + "\n").encode()))
def test_any_request_line_is_taken_or_refused_with_a_value_error(data):
    try:
        argv, cwd, env = serve.parse_request(data)
    except ValueError as e:
        assert str(e)
    else:
        assert argv and all(isinstance(a, str) for a in argv) and isinstance(cwd, str) and isinstance(env, dict)


def test_a_second_server_on_the_same_socket_is_refused(server):
    second = subprocess.run([*VILMA, "serve", "--socket", str(server.socket), "--warm-up", "none"],
                            capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
    assert second.returncode == 2
    assert second.stderr == f"vilma serve: error: a vilma server already listens at {server.socket}\n"


def test_a_changed_vilma_stops_the_server_and_its_client_runs_here(tmp_path):
    """(On a server of its own whose fingerprint a file gives: touching vilma's files would stop the servers of the
    tests running beside this one.)"""
    path, marker = tmp_path / "s.sock", tmp_path / "fingerprint"
    marker.write_text("before")
    with forked_server(path, fingerprint=marker.read_text) as server:
        marker.write_text("after")
        listed = subprocess.run([*VILMA, "scenarios"], cwd=tmp_path, env={**os.environ, "VILMA_SERVE": str(path)},
                                capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
        assert listed.returncode == 0 and f"{SCENARIO}: " in listed.stdout  # run by the client itself
        assert "vilma changed on disk since `vilma serve` started: start it again" in listed.stderr
        server.join(timeout=30)
        assert server.exitcode == 0
    assert not path.exists()


def test_the_fingerprint_changes_with_a_python_file_not_with_numba_s_caches(tmp_path, monkeypatch):
    package = tmp_path / "vilma"
    (package / "sim" / "__pycache__").mkdir(parents=True)
    (package / "sim" / "frame.py").write_text("x = 1\n")
    monkeypatch.setattr(serve, "PACKAGE", package)
    first = serve.fingerprint()
    (package / "sim" / "__pycache__" / "frame.run_frame-24.py311.nbi").write_bytes(b"index")
    assert serve.fingerprint() == first
    os.utime(package / "sim" / "frame.py", ns=(0, 10**9))
    assert serve.fingerprint() != first


def test_a_client_never_hands_its_streams_to_another_user_s_server(server, monkeypatch, capsys):
    monkeypatch.setenv("VILMA_SERVE", str(server.socket))
    monkeypatch.setattr(os, "getuid", lambda: os.geteuid() + 1)  # the server's user is then not ours
    assert serve.served(["scenarios"]) is None  # run here
    err = capsys.readouterr().err
    assert err == f"vilma: the server at {server.socket} is another user's; running the command here\n"


def test_a_warm_up_of_no_such_scenario_is_refused_in_one_line(tmp_path):
    out = subprocess.run([*VILMA, "serve", "--socket", str(tmp_path / "s.sock"), "--warm-up", "no_such_scenario"],
                         capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert out.returncode == 2
    assert out.stderr.startswith("vilma serve: error: --warm-up no_such_scenario: no such file")
    assert out.stderr.count("\n") == 1 and not (tmp_path / "s.sock").exists()


def test_a_socket_path_that_holds_a_file_or_is_too_long_is_refused_and_the_file_kept(tmp_path):
    kept = tmp_path / "notes.txt"
    kept.write_text("mine")
    for path, error in ((kept, f"{kept}: exists and is not a socket; give --socket a path of its own"),
                        (tmp_path / ("x" * 120 + ".sock"), "more than a socket's path may hold (107)")):
        out = subprocess.run([*VILMA, "serve", "--socket", str(path), "--warm-up", "none"], capture_output=True,
                             text=True, timeout=60, stdin=subprocess.DEVNULL)
        assert out.returncode == 2 and out.stderr.startswith("vilma serve: error: ") and error in out.stderr
        assert out.stderr.count("\n") == 1
    assert kept.read_text() == "mine"


def test_a_client_in_a_folder_deleted_meanwhile_runs_the_command_itself(server, tmp_path):
    gone = tmp_path / "gone"
    gone.mkdir()
    listed = server.client("scenarios", cwd=gone, preexec_fn=lambda: os.rmdir(gone))  # (removed once it is in it)
    assert listed.returncode == 0 and f"{SCENARIO}: " in listed.stdout and listed.stderr == ""


def test_a_client_whose_request_is_too_large_runs_the_command_itself(server, monkeypatch, capsys):
    monkeypatch.setenv("VILMA_SERVE", str(server.socket))
    monkeypatch.setenv("VILMA_TEST_BIG", "x" * serve.MAX_REQUEST)
    assert serve.served(["scenarios"]) is None  # run here
    err = capsys.readouterr().err
    assert err.startswith("vilma: the arguments and environment (") and err.endswith("running the command here\n")


@contextlib.contextmanager
def forked_server(path: Path, main=lambda argv, started=None: 0, **patches):
    """``serve.serve`` at ``path`` with ``main`` (no warm-up) in a process forked from this one, with ``serve``'s
    names in ``patches`` replaced; stopped by SIGTERM at the end (if still running)."""

    def run() -> None:
        for name, value in patches.items():
            setattr(serve, name, value)
        os._exit(serve.serve(path, main, warm_up=None, say=lambda *_: None))

    proc = multiprocessing.get_context("fork").Process(target=run)
    proc.start()
    try:
        while not path.exists() and proc.is_alive():
            time.sleep(0.01)
        yield proc
    finally:
        proc.terminate()  # SIGTERM: the server stops
        proc.join(timeout=30)


def test_a_server_runs_at_most_max_children_commands_and_then_refuses(tmp_path):
    path, release = tmp_path / "s.sock", tmp_path / "release"

    def until_released(argv, started=None) -> int:
        while not release.exists():
            time.sleep(0.01)
        return 0

    request = (json.dumps({"argv": ["scenarios"], "cwd": str(tmp_path), "env": {}}) + "\n").encode()
    with forked_server(path, until_released, MAX_CHILDREN=1) as server, open(os.devnull) as null, \
            socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as first:
        streams = [null.fileno()] * 3
        first.connect(str(path))
        socket.send_fds(first, [request], streams)
        answers = first.makefile("rb")
        assert "pid" in json.loads(answers.readline())  # running, until released
        assert _ask(path, request, streams) == {"error": "busy: already running 1 commands"}
        release.touch()
        assert json.loads(answers.readline()) == {"exit": 0}
        answer = {}
        for _ in range(500):  # until the server has reaped the first command
            answer = _ask(path, request, streams)
            if "pid" in answer:
                break
            time.sleep(0.01)
        assert "pid" in answer
    assert server.exitcode == 0


def test_a_signal_before_the_server_answers_reaches_the_command_once_it_runs(tmp_path):
    """A SIGTERM between the client's request and the server's answer is held, then sent to the command (it killed
    the client alone, leaving the command to notice it was gone)."""
    path, asked, release = tmp_path / "s.sock", tmp_path / "asked", tmp_path / "release"
    request = serve._request

    def held(conn: socket.socket):
        select.select([conn], [], [])  # the client has sent its request: its signals are forwarded from then on
        asked.touch()
        while not release.exists():
            time.sleep(0.01)
        return request(conn)

    def until_stopped(argv, started=None) -> int:
        time.sleep(60)  # (SIGTERM, the default in a command, ends it)
        return 0

    with forked_server(path, until_stopped, _request=held), Processes() as processes:
        client = processes.vilma("scenarios", cwd=tmp_path, env={**os.environ, "VILMA_SERVE": str(path)},
                                 stdin=subprocess.DEVNULL)
        while not asked.exists():
            time.sleep(0.01)
        client.send_signal(signal.SIGTERM)
        release.touch()
        assert client.wait(timeout=60) == 128 + signal.SIGTERM  # (not -SIGTERM: the client ended on its own)
