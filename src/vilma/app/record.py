"""The handlers of ``vilma report``, ``vilma export`` and ``vilma replay`` (the parser is in :mod:`vilma.app.cli`)."""

from __future__ import annotations

import argparse
import sys
import threading
from pathlib import Path

from vilma.app import programs
from vilma.app.options import scenario_or_default, zenoh_bus
from vilma.app.programs import stop_on_signals
from vilma.bus.local import LocalBus
from vilma.bus.nodes import publish_readings
from vilma.bus.topics import SENSOR_TOPICS, topic
from vilma.bus.zenoh_bus import DEFAULT_ENDPOINT
from vilma.core.closing import Closeable
from vilma.record.live import FoxgloveLive
from vilma.record.reader import Recording, read_recording
from vilma.record.replay import Replayer
from vilma.record.report import report, report_dir, world_counts
from vilma.record.road_scene import scenario_road
from vilma.record.ros1 import Ros1Bridge, init_node, rospy_or_reason, shutdown_node
from vilma.record.rosbag import export_rosbag2
from vilma.scenario.drive_log import DriveLog
from vilma.scenario.folder import RECORDING, claim
from vilma.scenario.result import RunObserver
from vilma.scenario.spec import Scenario
from vilma.sensors import Readings
from vilma.sim import Simulator


def report_command(args: argparse.Namespace) -> int:
    """``vilma report RUN.mcap [--out DIR]``: scorecard and plots from a recording alone (a run's folder: its
    ``run.mcap``), in a folder claimed as a run's (:func:`~vilma.scenario.folder.claim`); never the recording's
    own folder, whose run's files ``--overwrite`` would replace."""
    rec = _recording(args.recording)
    out = args.out or report_dir(rec.path)
    if out.is_dir() and out.samefile(rec.path.parent):
        raise ValueError(f"{out}: holds the recording {rec.path.name}; its report goes in a folder of its own (by "
                         f"default {report_dir(rec.path)}): choose another --out")
    claim([out], args.overwrite)
    result = report(rec, out)
    if args.quiet:  # what failed only
        for line in result.failures:
            print(f"FAIL {line}", file=sys.stderr)
        return 1 if result.failures else 0
    for k, v in result.metrics.items():
        print(f"{k:32s} {v}")
    if len(result.segments) > 1:
        print(f"{len(result.segments)} segments (the scorecard is the last one's; distance_m and sim_time_s their "
              "sums):")
        for i, s in enumerate(result.segments, 1):
            print(f"  {i}: from the {s['began']} at t={s['start_s']:.2f} s to t={s['sim_time_s']:.2f} s, "
                  f"{s['distance_m']:.2f} m, completed {s['completed']}")
    counts = world_counts(rec)
    if counts:
        print("world sensors: " + ", ".join(f"{name} {n}" for name, n in counts.items()))
    print(f"vilma report: metrics.json and plots in {result.out_dir}")
    for line in result.failures:
        print(f"FAIL {line}")
    return 1 if result.failures else 0


def _recording(name: str) -> Recording:
    """The recording ``name`` (a run's folder: its ``run.mcap``), read; one cut short is said on stderr, one without a
    message refused.

    Raises:
        ValueError: no recording there, or not a message in it.
    """
    path = Path(name)
    if path.is_dir():
        if not (path / RECORDING).is_file():
            raise ValueError(f"{path}: holds no {RECORDING} (a run with --no-record or --cars records none); give a "
                             "recording or a run's folder that has one")
        path = path / RECORDING
    rec = read_recording(path)
    if not any(rec.count(topic) for topic in rec.raw):
        raise ValueError(f"{path}: holds no messages{'' if rec.complete else ' (cut short before its first chunk)'}")
    if not rec.complete:
        print(f"vilma: {path} was cut short (no footer): read up to its last whole chunk", file=sys.stderr)
    return rec


def _seconds(text: str) -> float:
    """``text`` as a number of seconds, or a ValueError saying it is not one."""
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a number of seconds") from None


def export_command(args: argparse.Namespace) -> int:
    """``vilma export rosbag2 RUN.mcap OUTDIR`` (a run's folder: its ``run.mcap``)."""
    counts = export_rosbag2(_recording(args.recording), Path(args.out))
    print(f"vilma export: rosbag2 (MCAP storage) in {args.out}: "
          + ", ".join(f"{t} {n}" for t, n in counts.items()))
    return 0


def replay_command(args: argparse.Namespace) -> int:
    """``vilma replay RUN.mcap``: play onto Zenoh; stdin lines ``p`` (pause/resume), ``s T`` (seek to T s),
    ``x K`` (speed K), ``q`` (quit)."""

    rec = _recording(args.recording)
    bus, cfg = zenoh_bus(args, (DEFAULT_ENDPOINT,), ())
    with bus:
        player = Replayer(rec, bus, args.speed)
        if args.start:
            player.seek(args.start)
        print(f"vilma replay: {args.recording}, {(player.end_ns - player.start_ns) * 1e-9:.2f} s of sim time at "
              f"{args.speed:g}x on Zenoh {', '.join(cfg.listen) or '-'}; topics vilma/{player.car}/*. "
              "Type p (pause/resume), s T (seek), x K (speed), q (quit).", flush=True)
        with stop_on_signals() as stop:
            def commands() -> None:
                for line in sys.stdin:
                    word, *rest = line.split() or [""]
                    try:
                        if word == "p":
                            player.resume() if player.paused else player.pause()
                        elif word == "s" and rest:
                            player.seek(_seconds(rest[0]))
                        elif word == "x" and rest:
                            player.set_speed(_seconds(rest[0]))
                        elif word == "q":
                            stop.set()
                            return
                        elif word:
                            print("commands: p, s T, x K, q", flush=True)
                    except ValueError as e:
                        print(f"vilma replay: {e}", flush=True)

            threading.Thread(target=commands, daemon=True).start()
            player.start()
            while not stop.is_set() and not player.wait(0.2):
                pass
        player.close()
        print(f"vilma replay: {player.published} messages published", flush=True)
        return 0


def ros1_bridge_command(args: argparse.Namespace) -> int:
    """``vilma ros1-bridge [SCENARIO]``: the simulator (in-process, paced) on a ROS 1 master; with ``--connect``,
    the bus of a ``vilma sim`` elsewhere instead."""
    rospy, why = rospy_or_reason()
    if rospy is None:
        raise ValueError(why)
    try:
        init_node()  # rospy waits here for the master: Ctrl-C then must stop its threads too
        return _ros1_bridge(args)
    finally:
        shutdown_node()


def _ros1_bridge(args: argparse.Namespace) -> int:
    """The bridge, once the ROS node runs."""
    if args.connect or args.zenoh_config:
        bus, cfg = zenoh_bus(args, (), ())
        with bus, Ros1Bridge(bus, cmd_topic=args.cmd_topic), programs.stop_on_signals() as stop:
            print(f"vilma ros1-bridge: Zenoh {', '.join(cfg.connect)} <-> ROS 1; commands on {args.cmd_topic}",
                  flush=True)
            while not stop.wait(1.0):
                pass
        return 0
    scenario = scenario_or_default(args.scenario)
    with LocalBus() as bus, Ros1Bridge(bus, cmd_topic=args.cmd_topic):
        print(f"vilma ros1-bridge: simulator ({scenario.name}) at {args.speed:g}x real time on ROS 1: /pose "
              f"/velocity /gps /imu /wheelspeed; commands on {args.cmd_topic}", flush=True)
        return programs.sim_program(scenario, bus, args.speed, args.duration, lambda s: print(s, flush=True),
                                    morse=None)


class _LiveRun(Closeable):
    """Paced runs shown by a Foxglove server: their readings and the simulator's status put on a local bus that
    it serves, and a road scenario's road and traffic (where the run's simulator has it, reactive too)."""

    def __init__(self, port: int) -> None:
        self.bus = LocalBus()
        self.server = FoxgloveLive(self.bus, port=port)
        self._keys = {name: topic(name) for name in SENSOR_TOPICS}

    def watch(self, scenario: Scenario) -> list[RunObserver]:
        """The observers of a run of ``scenario``."""
        return [_Watch(self, scenario)]

    def close(self) -> None:
        """Stop the server and release the bus (closing again does nothing)."""
        self.server.close()
        self.bus.close()


class _Watch(RunObserver):
    """One run of ``scenario`` shown by ``live``."""

    def __init__(self, live: _LiveRun, scenario: Scenario) -> None:
        self.live, self.scenario = live, scenario

    def started(self, sim: Simulator, log: DriveLog) -> None:
        self.sim = sim
        self.live.server.show_road(scenario_road(self.scenario, sim.config))

    def add(self, readings: dict[str, Readings]) -> None:
        publish_readings(self.live.bus, self.live._keys, readings)
        self.live.bus.publish(topic("sim/status"), self.sim.status())  # Foxglove's clock, the scene's time


def foxglove_observer(port: int, realtime: float | None, say) -> _LiveRun:
    """``vilma run --realtime K --foxglove``: a Foxglove server fed with the run's readings."""
    if realtime is None:
        raise ValueError("--foxglove shows a run as it goes: give --realtime K too (e.g. --realtime 1)")
    live = _LiveRun(port)
    say(f"Foxglove: open connection ws://127.0.0.1:{live.server.port}")
    return live
