"""``vilma serve``: one warm process that runs this install's short commands, each in a child forked from it.

A ``vilma run`` of a 30 s drive spends nearly all of its second starting up: the interpreter, numpy, numba and the
loading of its compiled code, scipy, matplotlib. The server pays that once. Each ``vilma run``, ``demo``,
``report`` or ``scenarios`` started while it listens sends it its arguments, working directory, environment and
standard streams (the descriptors themselves, over the socket: a terminal stays a terminal); a child forked from
the warm process runs the command and answers its exit status, and Ctrl-C in the client reaches the command.
Without a server, or with ``VILMA_SERVE=off``, commands run in their own process as always.

Only the server's user may connect to its socket (its mode), and the server serves only its own user (the peer's
credentials). A server whose vilma changed on disk (a reinstall, an edit of an editable install) says so to the
next client, which runs the command itself, and stops. Only stdlib here: the client runs before the command's
imports.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import hashlib
import io
import json
import os
import signal
import socket
import stat
import struct
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from pathlib import Path

SERVED = ("run", "demo", "report", "scenarios")
"""The commands a server runs: those that end (not the GUI, servers or bridges)."""
MAX_SOCKET_PATH = 107
"""The longest path of a Unix socket on Linux [bytes] (``sun_path`` holds 108 with its final NUL)."""
MAX_REQUEST = 8 << 20
"""Longest request a server reads [bytes]: the arguments, working directory and environment as one JSON line (the
kernel holds a command's arguments and environment to ``ARG_MAX``, 2 MiB by default; JSON's escapes may double it)."""
MAX_CHILDREN = 64
"""Commands a server runs at once; a client beyond them runs its command itself."""
STOPS = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
"""The signals that stop a server (SIGHUP as :func:`vilma.app.cli.main` has it: a closed terminal), and a command."""
HELD = STOPS | {signal.SIGCHLD}
"""The signals a server holds over a fork: a stop (the fork's callbacks, logging's, would swallow its
KeyboardInterrupt), and a child's end until the child is counted."""
ENV = "VILMA_SERVE"
"""The environment variable that names the socket, or turns serving ``off``."""
PACKAGE = Path(__file__).resolve().parents[1]


def socket_path() -> Path | None:
    """Where this install's server listens: ``$VILMA_SERVE``, else a socket named for the install in the user's
    runtime folder; ``None`` with ``VILMA_SERVE=off``."""
    named = os.environ.get(ENV, "")
    if named:
        return None if named == "off" else Path(named)
    base = Path(os.environ.get("XDG_RUNTIME_DIR") or tempfile.gettempdir())
    install = hashlib.sha1(f"{sys.executable}\0{PACKAGE}".encode()).hexdigest()[:12]
    return base / f"vilma-{os.getuid()}" / f"serve-{install}.sock"


def fingerprint() -> str:
    """What says vilma's code changed on disk: a digest of its Python files' names, sizes and change times."""
    digest, stack = hashlib.sha1(), [PACKAGE]
    while stack:
        with os.scandir(stack.pop()) as entries:
            for e in sorted(entries, key=lambda e: e.name):
                if e.is_dir() and e.name != "__pycache__":
                    stack.append(Path(e.path))
                elif e.name.endswith(".py"):
                    info = e.stat()
                    digest.update(f"{e.path}\0{info.st_size}\0{info.st_mtime_ns}\0".encode())
    return digest.hexdigest()


Main = Callable[..., int]
"""``vilma.app.cli.main``: runs a command's arguments, its wall time counted from ``started`` (handed in: the
command line imports this module)."""


def add_options(parser: argparse.ArgumentParser) -> None:
    """``vilma serve``'s options."""
    parser.add_argument("--socket", metavar="PATH", help=f"where to listen (default: ${ENV}, else a socket named for "
                                                         "this install in the user's runtime folder)")
    parser.add_argument("--warm-up", default="course_30kmh_stanley", metavar="SCENARIO",
                        help="the scenario run once at the start, with its files, to load what runs use (default "
                             "course_30kmh_stanley: the planar plant's compiled loop and the plots; none: no run)")


def command(args: argparse.Namespace, main: Main) -> int:
    """``vilma serve``: serve until Ctrl-C; its exit status."""
    path = Path(args.socket) if args.socket else socket_path()
    if path is None:
        raise ValueError(f"serving is off ({ENV}=off): unset it or give --socket PATH")
    return serve(path, main, None if args.warm_up == "none" else args.warm_up, lambda line: print(line, flush=True))


# -- the client ------------------------------------------------------------------------------------------------


def served(argv: list[str]) -> int | None:
    """Run ``vilma ARGV`` on this install's server, if one listens; its exit status, or ``None`` to run it here."""
    name, path = command_of(argv), socket_path()
    if name not in SERVED or path is None or "_ARGCOMPLETE" in os.environ or not path.exists():
        return None
    try:
        for fd in (0, 1, 2):
            os.fstat(fd)
        cwd = os.getcwd()
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.connect(str(path))
    except OSError:  # no server behind the name (it ended), a standard stream closed, no folder: run here
        return None
    if _peer_uid(sock) != os.getuid():  # never hand our terminal and environment to another user's process
        sock.close()
        print(f"vilma: the server at {path} is another user's; running the command here", file=sys.stderr)
        return None
    request = json.dumps({"argv": argv, "cwd": cwd, "env": dict(os.environ)}).encode() + b"\n"
    if len(request) > MAX_REQUEST:
        sock.close()
        print(f"vilma: the arguments and environment ({len(request)} bytes as JSON) are more than the server takes "
              f"({MAX_REQUEST}); running the command here", file=sys.stderr)
        return None
    forwarded: list[int] = []
    pid: list[int] = []

    def send(signum: int) -> None:
        for p in pid:
            with contextlib.suppress(ProcessLookupError):
                os.kill(p, signum)

    def forward(signum: int, _) -> None:  # the command gets Ctrl-C, SIGTERM, SIGHUP (held until its pid is known)
        forwarded.append(signum)
        send(signum)

    before = {signum: signal.signal(signum, forward) for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
              if signal.getsignal(signum) != signal.SIG_IGN}  # (nohup's SIGHUP stays ignored)
    try:
        with sock, sock.makefile("rb") as answers:
            with contextlib.suppress(OSError):  # a server that stops answers before it reads: its answer tells
                socket.send_fds(sock, [request], [0, 1, 2])
            first = _read(answers)
            if "pid" not in first:
                if forwarded:  # stopped before the server answered: nothing ran
                    return 128 + forwarded[-1]
                print(f"vilma: {first.get('stale') or first.get('error') or 'no answer from the server'} "
                      f"(server at {path}); running the command here", file=sys.stderr)
                return None
            pid.append(first["pid"])
            for signum in forwarded:  # (sent before the server answered)
                send(signum)
            last = _read(answers)
    finally:
        for signum, handler in before.items():  # (the command may run here next)
            signal.signal(signum, handler)
    if "exit" in last:
        return int(last["exit"])
    if forwarded:  # the signal ended it: the status a shell gives a command that signal ended
        return 128 + forwarded[-1]
    print(f"vilma {name}: the served command ended without an exit status (server at {path})", file=sys.stderr)
    return 1


def _is_socket(path: Path) -> bool:
    """Whether ``path`` is a socket itself (not a link to one)."""
    try:
        return stat.S_ISSOCK(os.lstat(path).st_mode)
    except OSError:
        return False


def _peer_uid(sock: socket.socket) -> int:
    """The user id of the process at the other end of the Unix socket ``sock`` (Linux's peer credentials)."""
    return struct.unpack("3i", sock.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i")))[1]


def _read(answers: io.BufferedReader) -> dict:
    """The server's next answer line, ``{}`` at the end."""
    try:
        line = answers.readline(MAX_REQUEST)
    except OSError:
        return {}
    return json.loads(line) if line.endswith(b"\n") else {}


# -- the server ------------------------------------------------------------------------------------------------


def serve(path: Path, main: Main, warm_up: str | None = "course_30kmh_stanley", say=print) -> int:
    """Listen at ``path`` until interrupted (SIGINT, SIGTERM), or until vilma changes on disk, running each command
    with ``main``; returns 0. First run the scenario ``warm_up`` (a file or bundled name; ``None``: none), with its
    files, to load what commands use.

    Raises:
        ValueError: a server listens there already, or its folder is another user's.
    """
    _claim(path)
    if warm_up is not None:
        t0 = time.perf_counter()
        _warm_up(main, warm_up)
        say(f"vilma serve: warmed up on {warm_up} in {time.perf_counter() - t0:.1f} s")
    gc.freeze()  # the warm heap, as Python's docs advise before a fork: the children's collections skip it
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    mask = os.umask(0o177)  # the socket is born private (rw for its user only)
    try:
        listener.bind(str(path))
    except OSError as e:  # (another server bound it while this one warmed up)
        raise ValueError(f"cannot listen at {path} ({e.strerror}): another vilma server may have started there; "
                         "give --socket another path") from None
    finally:
        os.umask(mask)
    listener.listen(16)
    code, children = fingerprint(), set()

    def reap(*_) -> None:  # the commands that ended, reaped as they end
        with contextlib.suppress(ChildProcessError):
            while (pid := os.waitpid(-1, os.WNOHANG)[0]) > 0:
                children.discard(pid)

    signal.signal(signal.SIGCHLD, reap)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:  # from the line that says it listens: a client may interrupt it at once
        say(f"vilma serve: running `vilma {', '.join(SERVED)}` of {PACKAGE} for this user at {path} (Ctrl-C ends)")
        while True:
            conn, _ = listener.accept()
            with conn:
                if _peer_uid(conn) != os.getuid():
                    continue
                if fingerprint() != code:
                    _send(conn, {"stale": "vilma changed on disk since `vilma serve` started: start it again"})
                    say("vilma serve: vilma changed on disk; stopping")
                    return 0
                if len(children) >= MAX_CHILDREN:
                    _send(conn, {"error": f"busy: already running {MAX_CHILDREN} commands"})
                    continue
                signal.pthread_sigmask(signal.SIG_BLOCK, HELD)
                if (pid := os.fork()) == 0:
                    code = 1
                    try:
                        listener.close()
                        code = _child(conn, main, say)
                    finally:
                        os._exit(code)
                children.add(pid)
                signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD)
    except KeyboardInterrupt:
        return 0
    finally:
        listener.close()
        if _is_socket(path):  # (not a file put in its place since)
            path.unlink()


def _claim(path: Path) -> None:
    """Make ``path``'s folder (private), and remove a socket a server that ended left there.

    Raises:
        ValueError: ``path`` too long for a socket, in another user's folder, not a socket, or a server's.
    """
    if len(os.fsencode(path)) > MAX_SOCKET_PATH:
        raise ValueError(f"{path}: {len(os.fsencode(path))} bytes, more than a socket's path may hold "
                         f"({MAX_SOCKET_PATH}); give --socket a shorter one")
    try:
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        if path.parent.stat().st_uid != os.getuid():
            raise ValueError(f"{path.parent} is another user's: give --socket PATH in a folder of yours")
        if (path.exists() or path.is_symlink()) and not _is_socket(path):
            raise ValueError(f"{path}: exists and is not a socket; give --socket a path of its own")
    except OSError as e:
        raise ValueError(f"{path}: cannot make its folder ({e.strerror}); give --socket a path in a folder of yours")\
            from None
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        listener.connect(str(path))
    except OSError:
        path.unlink(missing_ok=True)  # a socket left by a server that ended
    else:
        listener.close()
        raise ValueError(f"a vilma server already listens at {path}")


def _warm_up(main: Main, scenario: str) -> None:
    """Run ``scenario`` with its files, in a folder then removed, so children start with what a run uses loaded.

    Raises:
        ValueError: no such scenario, a bad file, or the run failed to start.
    """
    import matplotlib

    matplotlib.use("Agg")  # what the plots use, before anything picks another backend
    from vilma.scenario import load_scenario

    try:
        load_scenario(scenario)
    except ValueError as e:  # the scenario's own words, on one line
        raise ValueError(f"--warm-up {e}") from None
    with tempfile.TemporaryDirectory() as tmp:
        if main(["run", scenario, "--out", tmp, "--overwrite", "-q"]) == 2:
            raise ValueError(f"the warm-up run of {scenario} failed (above); give another --warm-up, or none")


def _child(conn: socket.socket, main: Main, say) -> int:
    """Take one client's request on ``conn`` and run its command with its streams; its exit status."""
    for signum in (signal.SIGCHLD, signal.SIGTERM, signal.SIGHUP):  # the command's own, as in a process of its own
        signal.signal(signum, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD)
    try:
        argv, env, fds = _request(conn)
    except (OSError, ValueError) as e:
        say(f"vilma serve: refused a request: {e}")
        _send(conn, {"error": f"bad request: {e}"})
        return 2
    say(f"vilma serve: pid {os.getpid()}: vilma {' '.join(argv)}")
    for target, fd in enumerate(fds):
        os.dup2(fd, target)
        os.close(fd)
    _send(conn, {"pid": os.getpid()})
    os.environ.clear()
    os.environ.update(env)
    sys.argv = ["vilma", *argv]
    sys.stdin = open(0, closefd=False)  # noqa: SIM115 (the client's streams, open for the command's life)
    sys.stdout = open(1, "w", buffering=1 if os.isatty(1) else -1, closefd=False)  # noqa: SIM115
    sys.stderr = open(2, "w", buffering=1, closefd=False)  # noqa: SIM115
    import logging

    logging.getLogger().handlers.clear()  # the command sets up its own, on the client's stderr
    threading.Thread(target=_interrupt_when_gone, args=(conn,), daemon=True).start()
    try:
        code = main(argv, started=time.perf_counter())
    except SystemExit as e:  # argparse's --help and usage errors
        code = e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
    except BaseException:  # what a command in its own process would print
        import traceback

        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _send(conn, {"exit": code})
    return code


def _request(conn: socket.socket) -> tuple[list[str], dict[str, str], list[int]]:
    """The client's arguments, environment and three standard streams (descriptors); its working directory entered.

    Raises:
        ValueError: not such a request (the descriptors received are closed).
    """
    conn.settimeout(10.0)
    data, fds, _, _ = socket.recv_fds(conn, MAX_REQUEST, 3)
    while data and not data.endswith(b"\n") and len(data) < MAX_REQUEST:
        more = conn.recv(MAX_REQUEST - len(data))
        if not more:
            break
        data += more
    conn.settimeout(None)
    try:
        if len(fds) != 3:
            raise ValueError(f"expected the client's 3 standard streams, got {len(fds)} descriptors")
        argv, cwd, env = parse_request(data)
        os.chdir(cwd)
    except (ValueError, OSError):
        for fd in fds:
            os.close(fd)
        raise
    return argv, env, fds


def parse_request(data: bytes) -> tuple[list[str], str, dict[str, str]]:
    """A request line's arguments (of a served command), working directory and environment.

    Raises:
        ValueError: not one JSON line of at most :data:`MAX_REQUEST` bytes of that shape.
    """
    if not data.endswith(b"\n") or len(data) > MAX_REQUEST:
        raise ValueError(f"expected one JSON line of at most {MAX_REQUEST} bytes")
    try:
        req = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"not JSON ({e})") from None
    argv, cwd, env = (req.get(k) for k in ("argv", "cwd", "env")) if isinstance(req, dict) else (None,) * 3
    if not (isinstance(argv, list) and all(isinstance(a, str) for a in argv) and isinstance(cwd, str)
            and isinstance(env, dict) and all(isinstance(k, str) and isinstance(v, str) for k, v in env.items())):
        raise ValueError('expected {"argv": [strings], "cwd": string, "env": {string: string}}')
    if any("\0" in text for text in (*argv, cwd, *env, *env.values())) or any("=" in k or not k for k in env):
        raise ValueError("a NUL character in a string, or an environment variable named empty or with '='")
    if command_of(argv) not in SERVED:
        raise ValueError(f"the server runs only `vilma {' | '.join(SERVED)}`, not {argv!r}")
    return argv, cwd, env


def command_of(argv: list[str]) -> str | None:
    """The command of ``vilma ARGV``: its first argument that is not an option."""
    return next((a for a in argv if not a.startswith("-")), None)


def _interrupt_when_gone(conn: socket.socket) -> None:
    """Interrupt the command when its client goes away (killed): it stops as after Ctrl-C."""
    with contextlib.suppress(OSError):
        while conn.recv(4096):
            pass
    os.kill(os.getpid(), signal.SIGINT)


def _send(conn: socket.socket, answer: dict) -> None:
    with contextlib.suppress(OSError):  # the client is gone
        conn.sendall(json.dumps(answer).encode() + b"\n")
