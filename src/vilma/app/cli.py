# PYTHON_ARGCOMPLETE_OK
"""The ``vilma`` command."""

from __future__ import annotations

import argparse
import atexit
import contextlib
import errno
import logging
import os
import select
import signal
import sys
import threading
import time
from pathlib import Path

from vilma.app import arguments, collector, serve
from vilma.app.options import scenario_or_default, zenoh_bus
from vilma.core.extras import MissingExtraError, require

STARTED = time.perf_counter()
"""When the command began (its imports aside: a few ms): the first run's ``wall_time_s`` counts from here."""
PIPE_CLOSED = 128 + signal.SIGPIPE
"""The exit status of a command whose output's reader went away (``vilma scenarios | head -1``): 141, as a shell
reports a command that SIGPIPE ended (``seq 100000 | head -1``)."""
FAILED_WRITES = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO)
"""A write that failed although the command was right (a full disk, a quota, a file size limit, a failing device):
exit status 1, a failure, not 2, a mistake in the command line."""
STOPS = (signal.SIGTERM, signal.SIGHUP)
"""Signals that stop a command as Ctrl-C does (what it wrote kept as Ctrl-C keeps it, one line), with the status a
shell gives a command that signal ended: 128 + its number (143 for a job scheduler's or ``timeout``'s SIGTERM, 129
for the SIGHUP of a terminal that closed)."""


def _demo(args: argparse.Namespace) -> int:
    from vilma.app import batch, demo

    console = batch.Quiet() if args.quiet else _console(args)
    jobs = batch.plan(demo.scenario_names(), [])
    root = demo.out_root(args.out)
    console.print(f"vilma demo: {len(jobs)} bundled scenarios, headless, files in {root}", highlight=False)
    results = batch.run_all(jobs, root, args.realtime, console, overwrite=args.overwrite, started=STARTED)
    if not console.quiet:  # (the table imports rich)
        console.print(demo.comparison_table({r.scenario.name: r for r in results}))
    return _report_failures(results, console)


def _console(args: argparse.Namespace):
    """Where a command's progress and tables go: nowhere with ``--quiet``. A closed pipe (``| head``) raises
    ``BrokenPipeError`` for :func:`main` to end the command (rich's own answer is ``SystemExit(1)``: a failed run's)."""
    from rich.console import Console

    class _Console(Console):
        def on_broken_pipe(self) -> None:
            raise BrokenPipeError(errno.EPIPE, os.strerror(errno.EPIPE))

    return _Console(width=None if sys.stdout.isatty() else 160, quiet=args.quiet)


def _report_failures(results, console) -> int:
    failed = [r for r in results if not r.passed]
    for r in failed:
        for line in r.failures:  # --quiet keeps what failed, on stderr
            text = f"FAIL {r.scenario.name}: {line}"
            if console.quiet:
                print(text, file=sys.stderr)
            else:
                console.print(text, markup=False, highlight=False)
    return 1 if failed else 0


def _scenarios(args: argparse.Namespace) -> int:
    from vilma.scenario import bundled

    for name in bundled.names():
        print(f"{name}: {bundled.summary(bundled.BUNDLED / f'{name}.yaml')}")
    return 0


def _run(args: argparse.Namespace) -> int:
    from vilma.app import batch

    if args.workers is not None or args.scheduler is not None:
        if args.cars is not None or args.realtime is not None or args.foxglove is not None:
            raise ValueError("--workers and --scheduler run on Dask as fast as they can: drop --cars, --realtime "
                             "and --foxglove")
        return _sweep(args)
    if args.resume or args.keep_files or args.yes:
        raise ValueError("--resume, --keep-files and --yes are for runs on Dask: add --workers N or --scheduler")
    jobs = batch.plan(args.scenarios, [*args.set, *([f"plant={args.plant}"] if args.plant else [])])
    console = batch.Quiet() if args.quiet else _console(args)
    if args.cars is not None:
        if args.realtime is not None or args.foxglove is not None:
            raise ValueError("--cars drives the cars as fast as it can: drop --realtime and --foxglove")
        if args.plots:
            raise ValueError("--cars writes each car's files without plots or run.mcap: drop --plots")
        jobs = batch.as_cars(jobs, args.cars)
        results = batch.run_cars(jobs, args.out, console, args.overwrite)
    else:
        live = None
        if args.foxglove is not None:
            from vilma.app.record import foxglove_observer

            live = foxglove_observer(args.foxglove, args.realtime, console.print)
        with live or contextlib.nullcontext():
            results = batch.run_all(jobs, args.out, args.realtime, console,
                                    live.watch if live else lambda _: (), record=not args.no_record,
                                    plots=args.plots, overwrite=args.overwrite, started=STARTED)
    if not console.quiet:  # (rich would draw the tables, then drop them)
        if len(results) == 1:
            console.print(batch.scorecard_table(results[0]))
        console.print(batch.summary_table(jobs, results))
        for job, r in zip(jobs, results, strict=True):
            console.print(f"{job.scenario.file or job.scenario.name}{' ' + job.label if job.label else ''}: "
                          f"files in {r.out_dir}", markup=False, highlight=False)
    return _report_failures(results, console)


def _sweep(args: argparse.Namespace) -> int:
    """``vilma sweep SWEEP.yaml``, and ``vilma run ... --workers N | --scheduler ADDRESS``: the runs on Dask."""
    collector.started()  # a long wait on the cluster: the collector as usual
    require("sweep", f"vilma {args.command} on Dask")
    from vilma.app.sweep import sweep_command

    return sweep_command(args, _console(args))


def _tune(args: argparse.Namespace) -> int:
    """``vilma tune TUNE.yaml``: Optuna's search on Dask."""
    require("sweep", "vilma tune")
    from vilma.app.tune import tune_command

    return tune_command(args, _console(args))


def _trajectory(args: argparse.Namespace) -> int:
    import numpy as np

    from vilma.scenario.task import SmoothSpec
    from vilma.trajectory import (
        Trajectory,
        densify,
        load_trajectory,
        resample,
        save_trajectory,
        smooth_banded,
        smooth_iterative,
    )

    if args.action == "info" and args.output is not None:
        raise ValueError(f"trajectory info prints what it finds and writes nothing: drop {args.output}")
    path = load_trajectory(args.input)
    if args.action == "info":
        gaps = np.diff(path.s)
        kappa = np.abs(path.curvature).max() if len(path) > 2 else 0.0
        gaps = gaps if len(gaps) else np.zeros(1)
        print(f"{args.input}: {len(path)} points, {path.length:.2f} m long, spacing {gaps.mean():.3f} m "
              f"(min {gaps.min():.3f}, max {gaps.max():.3f}); "
              f"x {path.xy[:, 0].min():.2f}..{path.xy[:, 0].max():.2f} m, y {path.xy[:, 1].min():.2f}.."
              f"{path.xy[:, 1].max():.2f} m; tightest radius {1 / kappa if kappa > 0 else float('inf'):.2f} m; "
              f"{'with' if path.speed is not None else 'no'} speeds")
        return 0
    if args.output is None:
        raise ValueError(f"trajectory {args.action}: give the output file after the input")
    output = Path(args.output)
    if output.exists():
        if output.is_dir() or output.samefile(args.input):
            raise ValueError(f"{output}: is {'a folder' if output.is_dir() else 'the input'}; give another OUT file")
        if not args.overwrite:
            raise ValueError(f"{output}: exists; give --overwrite to replace it, or another OUT file")
    if args.action == "smooth":
        sm = SmoothSpec(alpha=args.alpha, beta=args.beta, tolerance=args.tolerance, solver=args.solver)
        xy = (smooth_iterative(path.xy, sm.alpha, sm.beta, sm.tolerance) if sm.solver == "iterative"
              else smooth_banded(path.xy, sm.alpha, sm.beta))
        out = Trajectory(xy, path.speed)
    elif args.action == "densify":
        out = densify(path, args.times)
    else:
        out = resample(path, args.spacing)
    save_trajectory(args.output, out)
    dropped = out.speed is not None and output.suffix.lower() != ".csv"
    print(f"{args.action}: {len(path)} -> {len(out)} points, written to {args.output}"
          + (" without its speeds (the original's format has none: write a .csv to keep them)" if dropped else ""))
    return 0


def _sim(args: argparse.Namespace) -> int:
    foxglove = _foxglove_port(args)
    from vilma.app import programs
    from vilma.bus.zenoh_bus import DEFAULT_ENDPOINT

    scenario = scenario_or_default(args.scenario, plant=args.plant)
    record = _record_path(args)
    morse = None if args.no_morse else programs.MorseOptions(
        args.morse_host, args.morse_port, args.morse_stream_port,
        tuple(args.allow_commands_from) if args.allow_commands_from else None)
    bus, cfg = zenoh_bus(args, (DEFAULT_ENDPOINT,), ())
    say = _say(args)
    say(f"vilma sim: {scenario.name}, {args.speed:g}x real time; Zenoh listens on {', '.join(cfg.listen) or '-'}, "
        f"connects to {', '.join(cfg.connect) or '-'}; topics vilma/vilma/*")
    with bus:
        return programs.sim_program(scenario, bus, args.speed, args.duration, say, morse,
                                    record=record, foxglove=foxglove)


def _drive(args: argparse.Namespace) -> int:
    from vilma.app import programs
    from vilma.bus.zenoh_bus import DEFAULT_ENDPOINT, LOOPBACK_ANY_PORT

    scenario = scenario_or_default(args.scenario) if args.scenario else None
    bus, cfg = zenoh_bus(args, (LOOPBACK_ANY_PORT,), (DEFAULT_ENDPOINT,))
    say = _say(args)
    say(f"vilma drive: {'task of ' + scenario.name if scenario else 'waiting for orders on vilma/vilma/driver/cmd'}; "
        f"Zenoh connects to {', '.join(cfg.connect) or '-'}")
    with bus:
        return programs.drive_program(scenario, bus, say, args.data_dir)


def _up(args: argparse.Namespace) -> int:
    foxglove = _foxglove_port(args)
    from vilma.app import programs

    scenario = scenario_or_default(args.scenario, "task: {course: [[0, 0], [100, 0], [100, -30], [50, -20], "
                                                     "[60, 0]], speed: 8.33}", args.plant)
    record = _record_path(args)
    say = _say(args)
    say(f"vilma up: {scenario.name} in one process on the local bus, {args.speed:g}x real time (Ctrl-C stops)")
    return programs.up(scenario, args.speed, args.duration, say, record, foxglove)


def _say(args: argparse.Namespace):
    """How a program prints its status lines: at once (another program may be reading), or not with ``--quiet``."""
    return (lambda line: None) if args.quiet else (lambda line: print(line, flush=True))


def _record_path(args: argparse.Namespace) -> Path | None:
    """The file of ``--record``, if given: a new one (an earlier recording is never replaced: the recording would
    truncate it at once, and a program stopped early would have lost it for a few seconds of drive).

    Raises:
        ValueError: something is there already.
    """
    if not args.record:
        return None
    path = Path(args.record)
    if path.exists() or path.is_symlink():
        raise ValueError(f"--record {path}: exists; give a new file (an earlier recording is never replaced)")
    return path


def _foxglove_port(args: argparse.Namespace) -> int | None:
    """``--foxglove``'s port, its extra checked before anything starts."""
    if args.foxglove is not None:
        require("foxglove", "the live Foxglove view")
    return args.foxglove


def _gui(args: argparse.Namespace) -> int:
    if not args.connect and (args.listen or args.zenoh_config):
        raise ValueError(f"{'--listen' if args.listen else '--zenoh-config'} is for joining programs on Zenoh: give "
                         "--connect ENDPOINT too (the embedded simulator needs no Zenoh)")
    from vilma.gui.app import main

    if args.connect:
        from vilma.bus.zenoh_bus import LOOPBACK_ANY_PORT

        scenario = scenario_or_default(args.scenario, plant=args.plant) if args.scenario else None
        return main(args, scenario=scenario, bus=zenoh_bus(args, (LOOPBACK_ANY_PORT,), ())[0])
    return main(args, scenario=scenario_or_default(args.scenario, plant=args.plant))


def _record_command(name: str):
    """The handler ``name`` of :mod:`vilma.app.record`, imported when it runs."""
    def handler(args: argparse.Namespace) -> int:
        from vilma.app import record as commands

        return getattr(commands, name)(args)
    return handler


HANDLERS = {"demo": _demo, "run": _run, "sweep": _sweep, "tune": _tune, "sim": _sim, "drive": _drive, "up": _up,
            "gui": _gui, "report": _record_command("report_command"), "export": _record_command("export_command"),
            "replay": _record_command("replay_command"), "ros1-bridge": _record_command("ros1_bridge_command"),
            "trajectory": _trajectory, "scenarios": _scenarios, "serve": lambda args: serve.command(args, main)}
"""What runs each subcommand (:data:`vilma.app.arguments.COMMANDS` holds its arguments)."""


def main(argv: list[str] | None = None, started: float | None = None) -> int:
    """Entry point: parse ``argv`` and run the subcommand, its run's wall time counted from ``started``
    [s, ``time.perf_counter``; default: the command's start]; returns the exit code. The command line's own command
    (``argv`` None) runs on ``vilma serve``'s warm process when one listens (:mod:`vilma.app.serve`)."""
    global STARTED
    STARTED = started or STARTED
    if argv is None and (code := serve.served(sys.argv[1:])) is not None:
        return code
    line = sys.argv[1:] if argv is None else argv
    completing = "_ARGCOMPLETE" in os.environ  # the shell asks for completions (argcomplete): only then import it
    parser = arguments.parser(None if completing else line)
    if completing:
        import argcomplete

        argcomplete.autocomplete(parser)
    args = parser.parse_args(line)
    logging.basicConfig(format="%(levelname)s %(name)s: %(message)s")
    quiet_or_verbose = logging.ERROR if args.quiet else max(logging.DEBUG, logging.WARNING - 10 * args.verbose)
    logging.getLogger().setLevel(quiet_or_verbose)  # set even when a handler exists (basicConfig would not)
    stops: list[int] = []
    try:
        with contextlib.nullcontext() if args.command == "gui" else _stopped_as_by_ctrl_c(stops):
            code = HANDLERS[args.command](args)
            sys.stdout.flush()  # what is still buffered: a closed pipe shows here, not at the exit
        return code
    except (ValueError, OSError, MissingExtraError) as e:
        if isinstance(e, BrokenPipeError) and (closed := _closed_outputs()):
            return _reader_gone(closed)
        print(f"vilma {args.command}: error: {e}", file=sys.stderr)
        return 1 if _failed(e) else 2
    except ModuleNotFoundError as e:
        if not _in_numba_cache(e):
            raise
        print(f"vilma {args.command}: error: {_stale_cache(e.name)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:
        if str(e):  # a run says where it stopped and what it kept
            print(f"vilma {args.command}: {e}", file=sys.stderr)
        return 128 + (stops[0] if stops else signal.SIGINT)


@contextlib.contextmanager
def _stopped_as_by_ctrl_c(stops: list[int]):
    """While the block runs, a :data:`STOPS` signal raises ``KeyboardInterrupt`` as Ctrl-C would (each signal is added
    to ``stops``); only the first: a repeat (``timeout`` sends its signal to the command and to its process group)
    lets the command finish what Ctrl-C's handling writes. A signal this process ignores (``nohup``) or handles
    itself stays so; the handlers come back after the block. Ctrl-C (SIGINT) raises as Python's own handler does. A
    signal that lands in llvmlite's code (numba compiling or loading), where a callback from C would print the
    ``KeyboardInterrupt`` and drop it, is sent again a moment later (:func:`_in_llvmlite`)."""
    def stop(signum: int, frame) -> None:
        if _in_llvmlite(frame):
            threading.Timer(0.05, os.kill, (os.getpid(), signum)).start()
            return
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        stops.append(signum)
        if len(stops) == 1:
            raise KeyboardInterrupt

    old = {}
    if threading.current_thread() is threading.main_thread():  # (signal handlers are set there only)
        for signum, python_s in ((signal.SIGINT, signal.default_int_handler), *((s, signal.SIG_DFL) for s in STOPS)):
            if signal.getsignal(signum) == python_s:
                old[signum] = signal.signal(signum, stop)
    try:
        yield
    finally:
        for signum, handler in old.items():
            signal.signal(signum, handler)


def _in_llvmlite(frame) -> bool:
    """Whether the Python frame ``frame`` runs in llvmlite's code, or is called from it."""
    while frame is not None:
        if frame.f_globals.get("__name__", "").startswith("llvmlite."):
            return True
        frame = frame.f_back
    return False


def _failed(e: BaseException) -> bool:
    """Whether ``e`` is a failure although the command was right: a peer lost on the way (a ``ConnectionError``: a
    Dask scheduler gone in the middle of a sweep), or a write that failed (:data:`FAILED_WRITES`), said by ``e`` or
    by the error it was raised while handling (a file's error said in its words)."""
    if isinstance(e, ConnectionError):
        return True
    while e is not None:
        if isinstance(e, OSError) and e.errno in FAILED_WRITES:
            return True
        e = e.__context__
    return False


def _in_numba_cache(e: BaseException) -> bool:
    """Whether ``e`` was raised while numba read its cache (an index names the types of every version it holds)."""
    tb = e.__traceback__
    while tb is not None:
        if Path(tb.tb_frame.f_code.co_filename).match("numba/core/caching.py"):
            return True
        tb = tb.tb_next
    return False


def _stale_cache(module: str | None) -> str:
    """What to do when numba's cache of vilma's compiled code names the types of a controller of ``module`` that this
    process cannot import: a script registered a controller kept outside vilma (its module on its own path) and
    drove with it, and numba kept that version beside the others."""
    import vilma
    from vilma.core.caches import numba_cache_of

    return (f"numba's cache of vilma's compiled code holds a version made for a controller of the module {module!r}, "
            f"which this process cannot import: put that module on Python's path (install it, or PYTHONPATH), or "
            f"delete the cache (vilma's .nbi and .nbc files in {numba_cache_of(str(Path(vilma.__file__).parent))}; "
            "the next run compiles again)")


def _closed_outputs() -> list[int]:
    """The standard output and error (1, 2) whose reader has gone: pipes closed at the other end (``| head -1``)."""
    poll = select.poll()
    for fd in (1, 2):
        poll.register(fd, 0)  # (an error is always reported)
    return [fd for fd, events in poll.poll(0) if events & select.POLLERR]


def _reader_gone(closed: list[int]) -> int:
    """End a command whose reader went away as Python's docs on SIGPIPE advise: quietly, the streams ``closed`` sent to
    /dev/null (nothing left in them fails at the exit); the status a shell gives a command SIGPIPE ended."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    for fd in closed:
        os.dup2(devnull, fd)
    os.close(devnull)
    return PIPE_CLOSED


def entry() -> None:
    """The ``vilma`` command (console script, ``python -m vilma``): :func:`main`, then the process ends.

    A command that :mod:`~vilma.app.serve` may serve starts with the garbage collector held off
    (:mod:`~vilma.app.collector`) and ends as its served child does: its files written and closed, the exit handlers
    run (:mod:`atexit`: logging, child processes, temporary folders), the streams flushed, then no interpreter teardown
    (``os._exit``: unloading numba's code and freeing every object cost 0.1-0.2 s of a 0.6 s ``vilma run``). Only with
    no other thread left: else (a Dask sweep's) the usual exit waits for them."""
    served = serve.command_of(sys.argv[1:]) in serve.SERVED
    if served:
        collector.starting()  # until the first run is done (app/batch.py)
    code = main()
    if served and threading.active_count() == 1:
        atexit._run_exitfuncs()  # as the interpreter's exit would, first
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(OSError, ValueError):  # a closed pipe (vilma run ... | head), a closed stream
                stream.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    entry()
