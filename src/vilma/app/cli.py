# PYTHON_ARGCOMPLETE_OK
"""The ``vilma`` command."""

from __future__ import annotations

import argparse
import atexit
import contextlib
import logging
import os
import sys
import threading
import time
from pathlib import Path

from vilma.app import collector, serve
from vilma.app.options import (
    MAX_CARS,
    PLANT_HELP,
    cars,
    complete_scenario,
    count,
    duration,
    folder,
    non_negative,
    plant,
    port,
    port_or_any,
    positive,
    scenario_or_default,
    sim_time,
    wall_delay,
    zenoh_bus,
)
from vilma.core.extras import MissingExtraError

STARTED = time.perf_counter()
"""When the command began (its imports aside: a few ms): the first run's ``wall_time_s`` counts from here."""


def _demo(args: argparse.Namespace) -> int:
    from vilma.app import batch, demo

    console = batch.Quiet() if args.quiet else _console(args)
    jobs = batch.plan(demo.scenario_names(), [])
    root = demo.out_root(Path(args.out) if args.out else None)
    console.print(f"vilma demo: {len(jobs)} bundled scenarios, headless, files in {root}", highlight=False)
    results = batch.run_all(jobs, root, args.realtime, console, overwrite=args.overwrite, started=STARTED)
    if not console.quiet:  # (the table imports rich)
        console.print(demo.comparison_table({r.scenario.name: r for r in results}))
    return _report_failures(results, console)


def _console(args: argparse.Namespace):
    """Where a command's progress and tables go: nowhere with ``--quiet``."""
    from rich.console import Console

    return Console(width=None if sys.stdout.isatty() else 160, quiet=args.quiet)


def _report_failures(results, console) -> int:
    failed = [r for r in results if not r.passed]
    for r in failed:
        for line in r.failures:  # --quiet keeps what failed, on stderr
            text = f"FAIL {r.scenario.name}: {line}"
            print(text, file=sys.stderr) if console.quiet else console.print(text, markup=False, highlight=False)
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
        results = batch.run_cars(jobs, Path(args.out) if args.out else None, console, args.overwrite)
    else:
        live = None
        if args.foxglove is not None:
            from vilma.app.record import foxglove_observer

            live = foxglove_observer(args.foxglove, args.realtime, console.print)
        with live or contextlib.nullcontext():
            results = batch.run_all(jobs, Path(args.out) if args.out else None, args.realtime, console,
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
    from vilma.core.extras import require

    require("sweep", f"vilma {args.command} on Dask")
    from vilma.app.sweep import sweep_command

    return sweep_command(args, _console(args))


def _tune(args: argparse.Namespace) -> int:
    """``vilma tune TUNE.yaml``: Optuna's search on Dask."""
    from vilma.core.extras import require

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
    print(f"{args.action}: {len(path)} -> {len(out)} points, written to {args.output}")
    return 0


def _sim(args: argparse.Namespace) -> int:
    from vilma.app import programs
    from vilma.bus.zenoh_bus import DEFAULT_ENDPOINT

    scenario = scenario_or_default(args.scenario, plant=args.plant)
    morse = None if args.no_morse else programs.MorseOptions(
        args.morse_host, args.morse_port, args.morse_stream_port,
        tuple(args.allow_commands_from) if args.allow_commands_from else None)
    bus, cfg = zenoh_bus(args, (DEFAULT_ENDPOINT,), ())
    say = _say(args)
    say(f"vilma sim: {scenario.name}, {args.speed:g}x real time; Zenoh listens on {', '.join(cfg.listen) or '-'}, "
        f"connects to {', '.join(cfg.connect) or '-'}; topics vilma/vilma/*")
    with bus:
        return programs.sim_program(scenario, bus, args.speed, args.duration, say, morse,
                                    record=_record_path(args), foxglove=args.foxglove)


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
    from vilma.app import programs

    scenario = scenario_or_default(args.scenario, "task: {course: [[0, 0], [100, 0], [100, -30], [50, -20], "
                                                     "[60, 0]], speed: 8.33}", args.plant)
    say = _say(args)
    say(f"vilma up: {scenario.name} in one process on the local bus, {args.speed:g}x real time (Ctrl-C stops)")
    return programs.up(scenario, args.speed, args.duration, say, _record_path(args), args.foxglove)


def _say(args: argparse.Namespace):
    """How a program prints its status lines: at once (another program may be reading), or not with ``--quiet``."""
    return (lambda line: None) if args.quiet else (lambda line: print(line, flush=True))


def _record_path(args: argparse.Namespace):
    return Path(args.record) if args.record else None


def _gui(args: argparse.Namespace) -> int:
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


def _parser() -> argparse.ArgumentParser:
    from vilma import __version__

    p = argparse.ArgumentParser(prog="vilma", description="Simulate, drive and monitor an autonomous car.")
    p.add_argument("--version", action="version", version=f"vilma {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    for add in (_add_runs, _add_programs, _add_gui, _add_recording_commands, _add_tools):
        add(sub)
    for q in sub.choices.values():
        loud = q.add_mutually_exclusive_group()
        loud.add_argument("-v", "--verbose", action="count", default=0, help="log more: -v info, -vv debug")
        loud.add_argument("-q", "--quiet", action="store_true", help="errors only: no progress bars, tables or notes")
    return p


def _add_runs(sub) -> None:
    """``vilma demo`` and ``vilma run``."""
    from vilma.scenario import bundled

    d = sub.add_parser("demo", help="the paper's figures and vilma's side by side: runs the bundled scenarios")
    d.add_argument("--out", metavar="DIR", help="where the runs' files go (default runs/demo-<timestamp>/)")
    d.add_argument("--overwrite", action="store_true", help="replace the files of earlier runs in --out")
    d.add_argument("--realtime", type=positive, default=None, metavar="K",
                   help="pace each run to K times real time (default: as fast as possible)")
    d.set_defaults(func=_demo)
    r = sub.add_parser("run", help="run scenario files headless and score them",
                       epilog=f"bundled scenarios (`vilma scenarios` describes them): {', '.join(bundled.names())}")
    r.add_argument("scenarios", nargs="+", metavar="SCENARIO",
                   help="scenario YAML files or bundled scenario names").completer = complete_scenario
    r.add_argument("--out", metavar="DIR", help="where the files go (default runs/<name>-<timestamp>/)")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a scenario value (dotted key, YAML value); KEY=a,b,c sweeps over the values")
    r.add_argument("--plant", type=plant, metavar="MODEL", help=PLANT_HELP)
    r.add_argument("--realtime", type=positive, default=None, metavar="K",
                   help="pace to K times real time (default: as fast as possible)")
    r.add_argument("--foxglove", nargs="?", type=port, const=8765, default=None, metavar="PORT",
                   help="with --realtime: serve the sensors live to Foxglove on ws://127.0.0.1:PORT (default 8765)")
    r.add_argument("--no-record", action="store_true", help="write no run.mcap (the other files as usual)")
    r.add_argument("--plots", action=argparse.BooleanOptionalAction, default=False,
                   help="draw path.png, speed.png, cross_track.png and effort.png too (default: not; they would "
                        "double a short run's time; `vilma report RUN` draws them later from run.mcap); with "
                        "--workers/--scheduler: the table's box plots")
    r.add_argument("--cars", type=cars, default=None, metavar="N",
                   help="drive N cars of each run side by side in the compiled loop, with the seeds seed, seed+1 ... "
                        f"(at most {MAX_CARS}); each writes its folder without plots or run.mcap")
    r.add_argument("--overwrite", action="store_true", help="replace the files of an earlier run in the --out folder "
                   "(without it, a folder that holds anything is refused)")
    _add_engine_options(r, "with --workers/--scheduler: ")
    r.set_defaults(func=_run)
    w = sub.add_parser("sweep", help="run a sweep file on Dask (scenarios x grid x samples x seeds): a results table")
    w.add_argument("sweep", metavar="SWEEP.yaml", help="the sweep file (scenarios, grid, samples, seeds)")
    w.add_argument("--out", metavar="DIR", help="where the table and plots go (default sweeps/<SWEEP>/)")
    w.add_argument("--plots", action=argparse.BooleanOptionalAction, default=True,
                   help="draw the box plots of the table (default: drawn)")
    _add_engine_options(w)
    w.set_defaults(func=_sweep)
    t = sub.add_parser("tune", help="search scenario values (gains) for a scorecard objective under constraints with "
                       "Optuna on Dask: the trials, best.yaml")
    t.add_argument("tune", metavar="TUNE.yaml", help="the tune file (scenarios, params, objective, constraints, "
                   "trials, seed)")
    t.add_argument("--out", metavar="DIR", help="where the trials, plot and best.yaml go (default tunes/<TUNE>/)")
    e = t.add_mutually_exclusive_group()
    e.add_argument("--workers", type=count, metavar="N", help="run on a local Dask cluster of N processes (default "
                   "one a core)")
    e.add_argument("--scheduler", metavar="ADDRESS", help="run on the Dask scheduler at ADDRESS (tcp://host:8786)")
    t.set_defaults(func=_tune)


def _add_engine_options(q, only: str = "") -> None:
    """Where a sweep runs (Dask), and what it keeps; ``only`` says when they apply."""
    e = q.add_mutually_exclusive_group()
    e.add_argument("--workers", type=count, metavar="N", help="run on a local Dask cluster of N processes "
                   "(vilma sweep: default one a core)")
    e.add_argument("--scheduler", metavar="ADDRESS", help="run on the Dask scheduler at ADDRESS (tcp://host:8786)")
    q.add_argument("--resume", action="store_true", help=f"{only}keep the finished runs in --out, run the rest")
    q.add_argument("--yes", action="store_true", help=f"{only}run more than 10,000 runs")
    q.add_argument("--keep-files", metavar="DIR", help=f"{only}each run writes its files in DIR/<key> (a folder the "
                   "workers can write)")


def _add_programs(sub) -> None:
    """The long-running programs on the bus: ``vilma sim``, ``drive`` and ``up``."""
    for name, helptext in (("sim", "the simulator as a server on Zenoh, paced to real time"),
                           ("drive", "the self-driver as its own process on Zenoh"),
                           ("up", "simulator and driver in one process, real time")):
        q = sub.add_parser(name, help=helptext)
        q.add_argument("scenario", nargs="?", metavar="SCENARIO", help="scenario file or bundled name (its car, "
                       "sensors, controllers and task)").completer = complete_scenario
        if name != "drive":
            q.add_argument("--plant", type=plant, metavar="MODEL", help=PLANT_HELP)
            q.add_argument("--speed", type=positive, default=1.0, metavar="K", help="K times real time (default 1)")
            q.add_argument("--duration", type=duration, default=float("inf"), help="stop after this sim time [s]")
            q.add_argument("--record", metavar="FILE", help="record every topic to this MCAP file (sim time)")
            q.add_argument("--foxglove", nargs="?", type=port, const=8765, default=None, metavar="PORT",
                           help="serve every topic live to Foxglove on ws://127.0.0.1:PORT (default 8765)")
        if name != "up":
            q.add_argument("--listen", action="append", metavar="ENDPOINT",
                           help="Zenoh endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable)")
            q.add_argument("--connect", action="append", metavar="ENDPOINT",
                           help="Zenoh endpoint to connect to (repeatable)")
            q.add_argument("--zenoh-config", metavar="FILE",
                           help="YAML file with listen, connect (lists of endpoints) and multicast_scouting")
        if name == "drive":
            q.add_argument("--data-dir", type=folder, metavar="DIR", help="follow orders on driver/cmd may name "
                           "trajectory files in DIR (default: none, orders carry their points)")
        q.set_defaults(func={"sim": _sim, "drive": _drive, "up": _up}[name])
        if name == "sim":
            _add_morse_options(q)


def _add_morse_options(q) -> None:
    """``vilma sim``'s MORSE socket interface."""
    q.add_argument("--morse-host", default="127.0.0.1", metavar="ADDR",
                   help="address of the MORSE socket interface (default 127.0.0.1; others are exposed)")
    q.add_argument("--morse-port", type=port_or_any, default=4000, metavar="PORT",
                   help="MORSE service port, the next free up to +9 (default 4000; 0: any free)")
    q.add_argument("--morse-stream-port", type=port_or_any, default=60000, metavar="PORT",
                   help="first MORSE datastream port (default 60000; 0: any free)")
    q.add_argument("--allow-commands-from", action="append", metavar="ADDR",
                   help="take MORSE commands only from this address or network (repeatable)")
    q.add_argument("--no-morse", action="store_true", help="do not serve the MORSE socket interface")


def _add_gui(sub) -> None:
    """``vilma gui``."""
    g = sub.add_parser("gui", help="the control and monitoring window (embedded simulator, or --connect)")
    g.add_argument("scenario", nargs="?", metavar="SCENARIO", help="embedded: scenario file or bundled name (car, "
                   "sensors, controllers; its path fills the table)").completer = complete_scenario
    g.add_argument("--connect", action="append", metavar="ENDPOINT",
                   help="join `vilma sim` / `vilma drive` over Zenoh at ENDPOINT, e.g. tcp/127.0.0.1:7447")
    g.add_argument("--listen", action="append", metavar="ENDPOINT", help="with --connect: Zenoh endpoint to listen on")
    g.add_argument("--zenoh-config", metavar="FILE", help="with --connect: YAML file with listen, connect")
    g.add_argument("--plant", type=plant, metavar="MODEL", help="embedded: " + PLANT_HELP)
    g.add_argument("--speed", type=positive, default=1.0, metavar="K", help="embedded: K times real time (default 1)")
    g.add_argument("--refresh", type=count, default=250, metavar="MS", help="Car Status refresh [ms] (default 250)")
    g.add_argument("--record-dir", metavar="DIR", help="where Record Trajectory / Speed write (default .)")
    g.add_argument("--quit-after", type=wall_delay, metavar="S", help="close after S wall seconds (for scripts)")
    g.set_defaults(func=_gui)


def _add_recording_commands(sub) -> None:
    """What works on recordings and ROS: ``report``, ``export``, ``replay``, ``ros1-bridge``."""
    rp = sub.add_parser("report", help="scorecard and plots of a recording (run.mcap) alone")
    rp.add_argument("recording", metavar="RUN.mcap", help="the recording, or a run's folder (its run.mcap)")
    rp.add_argument("--out", metavar="DIR", help="where metrics.json and the plots go (default RUN-report/)")
    rp.set_defaults(func=_record_command("report_command"))
    ex = sub.add_parser("export", help="a recording as a ROS 2 bag (rosbag2, MCAP storage, standard types)")
    ex.add_argument("format", choices=("rosbag2",))
    ex.add_argument("recording", metavar="RUN.mcap")
    ex.add_argument("out", metavar="OUTDIR", help="the bag's folder (must not exist)")
    ex.set_defaults(func=_record_command("export_command"))
    rl = sub.add_parser("replay", help="play a recording onto the bus (Zenoh) as if live: pause, seek, speed")
    rl.add_argument("recording", metavar="RUN.mcap")
    rl.add_argument("--speed", type=positive, default=1.0, metavar="K", help="K times real time (default 1)")
    rl.add_argument("--start", type=sim_time, default=0.0, metavar="S", help="start at sim time S [s]")
    rl.add_argument("--listen", action="append", metavar="ENDPOINT", help="Zenoh endpoint to listen on (repeatable)")
    rl.add_argument("--connect", action="append", metavar="ENDPOINT", help="Zenoh endpoint to connect to")
    rl.add_argument("--zenoh-config", metavar="FILE", help="YAML file with listen, connect and multicast_scouting")
    rl.set_defaults(func=_record_command("replay_command"))
    rb = sub.add_parser("ros1-bridge", help="the simulator's topics on a ROS 1 master (/pose, /velocity, /gps, /imu, "
                        "/wheelspeed) and commands from /cmd; needs Debian's ROS 1")
    rb.add_argument("scenario", nargs="?", metavar="SCENARIO",
                    help="scenario file or bundled name (its car, sensors)").completer = complete_scenario
    rb.add_argument("--speed", type=positive, default=1.0, metavar="K", help="K times real time (default 1)")
    rb.add_argument("--duration", type=duration, default=float("inf"), help="stop after this sim time [s]")
    rb.add_argument("--cmd-topic", default="/cmd", help="ROS topic of actuator commands (default /cmd)")
    rb.add_argument("--connect", action="append", metavar="ENDPOINT",
                    help="bridge the Zenoh bus of a vilma sim at ENDPOINT instead of simulating here")
    rb.add_argument("--listen", action="append", metavar="ENDPOINT", help=argparse.SUPPRESS)
    rb.add_argument("--zenoh-config", metavar="FILE", help="YAML file with listen, connect and multicast_scouting")
    rb.set_defaults(func=_record_command("ros1_bridge_command"))


def _add_tools(sub) -> None:
    """``vilma trajectory`` and ``vilma scenarios``."""
    from vilma.trajectory.defaults import ALPHA, BETA, TOLERANCE

    t = sub.add_parser("trajectory", help="trajectory tools: info, smooth, densify, resample",
                       description="Read a trajectory (the original's x y pairs, CSV x,y[,speed] or GPX), "
                                   "transform it and write it (.csv: CSV, else the original's format).")
    t.add_argument("action", choices=("info", "smooth", "densify", "resample"))
    t.add_argument("input", metavar="IN")
    t.add_argument("output", metavar="OUT", nargs="?")
    t.add_argument("--alpha", type=positive, default=ALPHA, help=f"smooth: weight_data (default {ALPHA})")
    t.add_argument("--beta", type=non_negative, default=BETA, help=f"smooth: weight_smooth (default {BETA})")
    t.add_argument("--tolerance", type=positive, default=TOLERANCE, help=f"smooth: tolerance [m] (default {TOLERANCE})")
    t.add_argument("--solver", choices=("iterative", "banded"), default="iterative",
                   help="smooth: the paper's sweeps or the direct banded solution (same fixed point)")
    t.add_argument("--times", type=count, default=1, help="densify: Increase Point Count this many times (default 1)")
    t.add_argument("--spacing", type=positive, default=0.5, help="resample: spacing [m] (default 0.5)")
    t.set_defaults(func=_trajectory)
    sc = sub.add_parser("scenarios", help="the bundled scenarios, one line each (run them by name)")
    sc.set_defaults(func=_scenarios)
    sv = sub.add_parser("serve", help="stay warm and run this install's `vilma run`, `demo`, `report` and "
                                      "`scenarios` in a tenth of their start-up (until Ctrl-C)")
    serve.add_options(sv)
    sv.set_defaults(func=lambda args: serve.command(args, main))


def main(argv: list[str] | None = None, started: float | None = None) -> int:
    """Entry point: parse ``argv`` and run the subcommand, its run's wall time counted from ``started``
    [s, ``time.perf_counter``; default: the command's start]; returns the exit code. The command line's own command
    (``argv`` None) runs on ``vilma serve``'s warm process when one listens (:mod:`vilma.app.serve`)."""
    global STARTED
    STARTED = started or STARTED
    if argv is None and (code := serve.served(sys.argv[1:])) is not None:
        return code
    parser = _parser()
    if "_ARGCOMPLETE" in os.environ:  # the shell asks for completions (argcomplete): only then import it
        import argcomplete

        argcomplete.autocomplete(parser)
    args = parser.parse_args(argv)
    logging.basicConfig(format="%(levelname)s %(name)s: %(message)s")
    quiet_or_verbose = logging.ERROR if args.quiet else max(logging.DEBUG, logging.WARNING - 10 * args.verbose)
    logging.getLogger().setLevel(quiet_or_verbose)  # set even when a handler exists (basicConfig would not)
    try:
        return args.func(args)
    except (ValueError, OSError, MissingExtraError) as e:
        print(f"vilma {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:
        if str(e):  # a run says where it stopped and what it kept
            print(f"vilma {args.command}: {e}", file=sys.stderr)
        return 130


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
