"""The ``vilma`` command's arguments: a subparser for each subcommand, filled only for the one a command line asks
for (the others' arguments cost a ``vilma run`` 2-3 ms of its start)."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence

from vilma.app import serve
from vilma.app.options import (
    MAX_CARS,
    PLANT_HELP,
    bind_address,
    cars,
    complete_scenario,
    connect_endpoint,
    count,
    duration,
    first_stream_port,
    folder,
    listen_endpoint,
    non_negative,
    out_folder,
    plant,
    port,
    port_or_any,
    positive,
    scheduler,
    sim_time,
    wall_delay,
)


def parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of ``vilma``. Given ``argv`` that begins with a subcommand, only that subcommand's parser is made;
    else (``vilma --help``, a mistyped subcommand) every subcommand is listed, and with ``argv`` None (the shell's
    completion, tests) every one is filled."""
    from vilma import __version__

    p = argparse.ArgumentParser(prog="vilma", description="Simulate, drive and monitor an autonomous car.")
    p.add_argument("--version", action="version", version=f"vilma {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    asked = argv[0] if argv and argv[0] in COMMANDS else None
    for name, (helptext, fill) in COMMANDS.items():
        if asked is None or name == asked:
            q = sub.add_parser(name, help=helptext)
            if argv is None or name == asked:
                fill(q)
                loud = q.add_mutually_exclusive_group()
                loud.add_argument("-v", "--verbose", action="count", default=0, help="log more: -v info, -vv debug")
                loud.add_argument("-q", "--quiet", action="store_true",
                                  help="errors only: no progress bars, tables or notes")
    return p


def _demo(d: argparse.ArgumentParser) -> None:
    d.add_argument("--out", type=out_folder, metavar="DIR",
                   help="where the runs' files go (default runs/demo-<timestamp>/)")
    d.add_argument("--overwrite", action="store_true", help="replace the files of earlier runs in --out")
    d.add_argument("--realtime", type=positive, default=None, metavar="K",
                   help="pace each run to K times real time (default: as fast as possible)")


def _run(r: argparse.ArgumentParser) -> None:
    from vilma.scenario import bundled

    r.epilog = f"bundled scenarios (`vilma scenarios` describes them): {', '.join(bundled.names())}"
    r.add_argument("scenarios", nargs="+", metavar="SCENARIO",
                   help="scenario YAML files or bundled scenario names").completer = complete_scenario
    r.add_argument("--out", type=out_folder, metavar="DIR",
                   help="where the files go (default runs/<name>-<timestamp>/)")
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
    _engine(r, "with --workers/--scheduler: ")


def _sweep(w: argparse.ArgumentParser) -> None:
    w.add_argument("sweep", metavar="SWEEP.yaml", help="the sweep file (scenarios, grid, samples, seeds)")
    w.add_argument("--out", type=out_folder, metavar="DIR",
                   help="where the table and plots go (default sweeps/<SWEEP>/)")
    w.add_argument("--plots", action=argparse.BooleanOptionalAction, default=True,
                   help="draw the box plots of the table (default: drawn)")
    _engine(w)


def _tune(t: argparse.ArgumentParser) -> None:
    t.add_argument("tune", metavar="TUNE.yaml", help="the tune file (scenarios, params, objective, constraints, "
                   "trials, seed)")
    t.add_argument("--out", type=out_folder, metavar="DIR",
                   help="where the trials, plot and best.yaml go (default tunes/<TUNE>/)")
    _cluster(t, "")


def _engine(q: argparse.ArgumentParser, only: str = "") -> None:
    """Where a sweep runs (Dask), and what it keeps; ``only`` says when they apply."""
    _cluster(q, "vilma sweep: ")
    q.add_argument("--resume", action="store_true", help=f"{only}keep the finished runs in --out, run the rest")
    q.add_argument("--yes", action="store_true", help=f"{only}run more than 10,000 runs")
    q.add_argument("--keep-files", metavar="DIR", help=f"{only}each run writes its files in DIR/<key> (a folder the "
                   "workers can write)")


def _cluster(q: argparse.ArgumentParser, which: str) -> None:
    """``--workers`` or ``--scheduler``; ``which`` says whose default is one worker a core."""
    e = q.add_mutually_exclusive_group()
    e.add_argument("--workers", type=count, metavar="N", help=f"run on a local Dask cluster of N processes ({which}"
                   "default one a core)")
    e.add_argument("--scheduler", type=scheduler, metavar="ADDRESS",
                   help="run on the Dask scheduler at ADDRESS (tcp://host:8786)")


def _program(name: str) -> Callable[[argparse.ArgumentParser], None]:
    """The arguments of the long-running programs on the bus: ``vilma sim``, ``drive`` and ``up``."""
    def fill(q: argparse.ArgumentParser) -> None:
        q.add_argument("scenario", nargs="?", metavar="SCENARIO", help="scenario file or bundled name (its car, "
                       "sensors, controllers and task)").completer = complete_scenario
        if name != "drive":
            q.add_argument("--plant", type=plant, metavar="MODEL", help=PLANT_HELP)
            q.add_argument("--speed", type=positive, default=1.0, metavar="K", help="K times real time (default 1)")
            q.add_argument("--duration", type=duration, default=float("inf"), help="stop after this sim time [s]")
            q.add_argument("--record", metavar="FILE",
                           help="record every topic to this new MCAP file (sim time)")
            q.add_argument("--foxglove", nargs="?", type=port, const=8765, default=None, metavar="PORT",
                           help="serve every topic live to Foxglove on ws://127.0.0.1:PORT (default 8765)")
        if name != "up":
            _zenoh_options(q)
        if name == "drive":
            q.add_argument("--data-dir", type=folder, metavar="DIR", help="follow orders on driver/cmd may name "
                           "trajectory files in DIR (default: none, orders carry their points)")
        if name == "sim":
            _morse(q)
    return fill


def _morse(q: argparse.ArgumentParser) -> None:
    """``vilma sim``'s MORSE socket interface."""
    q.add_argument("--morse-host", type=bind_address, default="127.0.0.1", metavar="ADDR",
                   help="address of the MORSE socket interface (default 127.0.0.1; others are exposed)")
    q.add_argument("--morse-port", type=port_or_any, default=4000, metavar="PORT",
                   help="MORSE service port, the next free up to +9 (default 4000; 0: any free)")
    q.add_argument("--morse-stream-port", type=first_stream_port, default=60000, metavar="PORT",
                   help="first MORSE datastream port (default 60000; 0: any free)")
    q.add_argument("--allow-commands-from", action="append", metavar="ADDR",
                   help="take MORSE commands only from this address or network (repeatable)")
    q.add_argument("--no-morse", action="store_true", help="do not serve the MORSE socket interface")


def _gui(g: argparse.ArgumentParser) -> None:
    g.add_argument("scenario", nargs="?", metavar="SCENARIO", help="embedded: scenario file or bundled name (car, "
                   "sensors, controllers; its path fills the table)").completer = complete_scenario
    g.add_argument("--connect", action="append", type=connect_endpoint, metavar="ENDPOINT",
                   help="join `vilma sim` / `vilma drive` over Zenoh at ENDPOINT, e.g. tcp/127.0.0.1:7447")
    g.add_argument("--listen", action="append", type=listen_endpoint, metavar="ENDPOINT",
                   help="with --connect: Zenoh endpoint to listen on")
    g.add_argument("--zenoh-config", metavar="FILE", help="with --connect: YAML file with listen, connect")
    g.add_argument("--plant", type=plant, metavar="MODEL", help="embedded: " + PLANT_HELP)
    g.add_argument("--speed", type=positive, default=1.0, metavar="K", help="embedded: K times real time (default 1)")
    g.add_argument("--refresh", type=count, default=250, metavar="MS", help="Car Status refresh [ms] (default 250)")
    g.add_argument("--record-dir", type=folder, metavar="DIR",
                   help="where Record Trajectory / Speed write, a folder that exists (default .)")
    g.add_argument("--quit-after", type=wall_delay, metavar="S", help="close after S wall seconds (for scripts)")


def _report(rp: argparse.ArgumentParser) -> None:
    rp.add_argument("recording", metavar="RUN.mcap", help="the recording, or a run's folder (its run.mcap)")
    rp.add_argument("--out", type=out_folder, metavar="DIR",
                    help="where metrics.json and the plots go (default RUN-report/; a new or empty folder)")
    rp.add_argument("--overwrite", action="store_true", help="replace the files of an earlier report in the --out "
                    "folder (without it, a folder that holds anything is refused)")


def _export(ex: argparse.ArgumentParser) -> None:
    ex.add_argument("format", choices=("rosbag2",))
    ex.add_argument("recording", metavar="RUN.mcap")
    ex.add_argument("out", metavar="OUTDIR", help="the bag's folder (must not exist)")


def _zenoh_options(p: argparse.ArgumentParser) -> None:
    """``--listen``, ``--connect`` and ``--zenoh-config``: how a program joins the others on Zenoh."""
    p.add_argument("--listen", action="append", type=listen_endpoint, metavar="ENDPOINT",
                   help="Zenoh endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable)")
    p.add_argument("--connect", action="append", type=connect_endpoint, metavar="ENDPOINT",
                   help="Zenoh endpoint to connect to (repeatable)")
    p.add_argument("--zenoh-config", metavar="FILE",
                   help="YAML file with listen, connect (lists of endpoints), multicast_scouting and extra")


def _replay(rl: argparse.ArgumentParser) -> None:
    rl.add_argument("recording", metavar="RUN.mcap")
    rl.add_argument("--speed", type=positive, default=1.0, metavar="K", help="K times real time (default 1)")
    rl.add_argument("--start", type=sim_time, default=0.0, metavar="S", help="start at sim time S [s]")
    _zenoh_options(rl)


def _ros1_bridge(rb: argparse.ArgumentParser) -> None:
    rb.add_argument("scenario", nargs="?", metavar="SCENARIO",
                    help="scenario file or bundled name (its car, sensors)").completer = complete_scenario
    rb.add_argument("--speed", type=positive, default=1.0, metavar="K", help="K times real time (default 1)")
    rb.add_argument("--duration", type=duration, default=float("inf"), help="stop after this sim time [s]")
    rb.add_argument("--cmd-topic", default="/cmd", help="ROS topic of actuator commands (default /cmd)")
    rb.add_argument("--connect", action="append", type=connect_endpoint, metavar="ENDPOINT",
                    help="bridge the Zenoh bus of a vilma sim at ENDPOINT instead of simulating here")
    rb.add_argument("--listen", action="append", type=listen_endpoint, metavar="ENDPOINT", help=argparse.SUPPRESS)
    rb.add_argument("--zenoh-config", metavar="FILE",
                    help="YAML file with listen, connect, multicast_scouting and extra")


def _trajectory(t: argparse.ArgumentParser) -> None:
    from vilma.trajectory.defaults import ALPHA, BETA, TOLERANCE

    t.description = ("Read a trajectory (the original's x y pairs, CSV x,y[,speed] or GPX), transform it and write it "
                     "(.csv: CSV, else the original's format).")
    t.add_argument("action", choices=("info", "smooth", "densify", "resample"))
    t.add_argument("input", metavar="IN")
    t.add_argument("output", metavar="OUT", nargs="?")
    t.add_argument("--overwrite", action="store_true", help="replace OUT if it exists (never IN)")
    t.add_argument("--alpha", type=positive, default=ALPHA, help=f"smooth: weight_data (default {ALPHA})")
    t.add_argument("--beta", type=non_negative, default=BETA, help=f"smooth: weight_smooth (default {BETA})")
    t.add_argument("--tolerance", type=positive, default=TOLERANCE, help=f"smooth: tolerance [m] (default {TOLERANCE})")
    t.add_argument("--solver", choices=("iterative", "banded"), default="iterative",
                   help="smooth: the paper's sweeps or the direct banded solution (same fixed point)")
    t.add_argument("--times", type=count, default=1, help="densify: Increase Point Count this many times (default 1)")
    t.add_argument("--spacing", type=positive, default=0.5, help="resample: spacing [m] (default 0.5)")


COMMANDS: dict[str, tuple[str, Callable[[argparse.ArgumentParser], None]]] = {
    "demo": ("the paper's figures and vilma's side by side: runs the bundled scenarios", _demo),
    "run": ("run scenario files headless and score them", _run),
    "sweep": ("run a sweep file on Dask (scenarios x grid x samples x seeds): a results table", _sweep),
    "tune": ("search scenario values (gains) for a scorecard objective under constraints with Optuna on Dask: the "
             "trials, best.yaml", _tune),
    "sim": ("the simulator as a server on Zenoh, paced to real time", _program("sim")),
    "drive": ("the self-driver as its own process on Zenoh", _program("drive")),
    "up": ("simulator and driver in one process, real time", _program("up")),
    "gui": ("the control and monitoring window (embedded simulator, or --connect)", _gui),
    "report": ("scorecard and plots of a recording (run.mcap) alone", _report),
    "export": ("a recording as a ROS 2 bag (rosbag2, MCAP storage, standard types)", _export),
    "replay": ("play a recording onto the bus (Zenoh) as if live: pause, seek, speed", _replay),
    "ros1-bridge": ("the simulator's topics on a ROS 1 master (/pose, /velocity, /gps, /imu, /wheelspeed) and "
                    "commands from /cmd; needs Debian's ROS 1", _ros1_bridge),
    "trajectory": ("trajectory tools: info, smooth, densify, resample", _trajectory),
    "scenarios": ("the bundled scenarios, one line each (run them by name)", lambda _: None),
    "serve": ("stay warm and run this install's `vilma run`, `demo`, `report` and `scenarios` in a tenth of their "
              "start-up (until Ctrl-C)", serve.add_options),
}
"""Each subcommand's help line, and what adds its arguments."""
