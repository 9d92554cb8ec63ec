"""Recordings made by the programs: ``vilma run`` writes run.mcap; ``vilma up`` / ``vilma sim`` with ``--record``
hold the scenario and the orders the driver took, and survive SIGTERM (finished file) and SIGKILL (readable up to
the last flushed chunk, reported as cut short)."""

from __future__ import annotations

import csv
import math
import signal
import subprocess
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from tests.conftest import Processes
from vilma.app import programs
from vilma.app.batch import BUNDLED
from vilma.app.cli import main
from vilma.bus.local import LocalBus
from vilma.bus.nodes import DriverNode, SimNode
from vilma.bus.topics import topic
from vilma.control.driver import Driver
from vilma.core.messages import DriverOrder
from vilma.record.reader import read_recording
from vilma.record.recorder import BusRecorder, Recorder
from vilma.record.report import report
from vilma.record.run import record_run
from vilma.scenario import load_scenario, to_yaml
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.spec import TIMING_KEYS
from vilma.sim import Simulator

POSE_PERIOD_NS = 20_000_000
"""The pose sensor's default period (50 Hz)."""


def test_run_writes_run_mcap_equal_to_its_log_and_timeseries(tmp_path):
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    result = record_run(scenario, tmp_path)
    back = read_recording(tmp_path / "run.mcap")
    assert back.complete
    assert np.array_equal(back.drive_log(), result.log.rows, equal_nan=True)
    with (tmp_path / "timeseries.csv").open() as f:
        table = list(csv.DictReader(f))
    pose = back.readings("pose")
    logged = [(round(float(r["t_s"]) * 1e9), float(r["pose.x"]), float(r["pose.yaw"])) for r in table if r["pose.x"]]
    assert [(int(t), x, yaw) for t, x, yaw in zip(pose.stamp_ns, pose.field("x"), pose.field("yaw"),
                                                   strict=True)] == logged
    assert np.all(np.diff(pose.stamp_ns) == POSE_PERIOD_NS)
    for name in ("velocity", "gps", "imu", "wheel_speed", "odometry", "actuators"):
        first = back.readings(name).message.__struct_fields__[1]
        assert back.count(name) == sum(1 for r in table if r[f"{name}.{first}"])
    recorded = back.meta("scorecard")  # as the run finished the file; the files' share of the time came after
    assert {k: v for k, v in recorded.items() if k not in TIMING_KEYS} == \
        {k: v for k, v in result.metrics.items() if k not in TIMING_KEYS}
    assert recorded["loop_wall_time_s"] == result.metrics["loop_wall_time_s"] and recorded["load_time_s"] is not None
    assert back.attachments["scenario.yaml"].decode() == to_yaml(scenario)
    assert back.meta("run")["t_start"] == result.t_start
    xy = np.loadtxt(back.attachments["path.csv"].decode().splitlines(), delimiter=",")
    assert np.array_equal(xy[:, :2], result.path.xy)
    with (tmp_path / "run.mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary.statistics.message_count == sum(back.count(t) for t in back.topics)
    assert len(COLUMNS) == back.drive_log().shape[1]


def test_run_no_record_writes_the_other_files_only(tmp_path):
    assert main(["run", "paper_fig11_speed_10", "--no-record", "--plots", "--out", str(tmp_path)]) == 0
    assert not (tmp_path / "run.mcap").exists()
    assert {"metrics.json", "timeseries.csv", "scenario.yaml", "speed.png"} <= {p.name for p in tmp_path.iterdir()}


def test_up_records_every_topic_and_a_failing_path_does_not_stop_the_drive(tmp_path):
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    lines: list[str] = []
    assert programs.up(scenario, 50.0, 2.0, lines.append, record=tmp_path / "up.mcap") == 0
    back = read_recording(tmp_path / "up.mcap")
    assert back.complete
    assert {"pose", "tf", "velocity", "gps", "imu", "wheel_speed", "odometry", "actuators", "cmd", "driver/status",
            "sim/status"} <= set(back.topics)
    with (tmp_path / "up.mcap").open("rb") as f:  # Foxglove's ROS 2 decoder reads every CDR topic from the file
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        cdr = [c.topic for c in reader.get_summary().channels.values() if c.message_encoding == "cdr"]
        decoded = Counter(ch.topic for _, ch, _, _ in reader.iter_decoded_messages(topics=cdr))
    assert decoded == {f"vilma/vilma/{t}": back.count(t) for t in back.topics if back.encodings[t] == "cdr"}
    assert len(decoded) == 12  # 7 sensors, tf, and the 4 topics beside pose, velocity, gps and odometry
    pose = back.readings("pose")
    assert pose.stamp_ns[-1] == 2_000_000_000 and np.all(np.diff(pose.stamp_ns) == POSE_PERIOD_NS)
    cmds = back.messages("cmd")
    assert cmds and all(c.autonomous for c in cmds)
    # the same drive without a usable file: it runs to its end all the same
    again: list[str] = []
    assert programs.up(scenario, 50.0, 2.0, again.append, record=tmp_path / "missing" / "up.mcap") == 0
    assert len(again) == len(lines) == 2


def test_sim_program_records_what_it_publishes(tmp_path):
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    bus = LocalBus()
    assert programs.sim_program(scenario, bus, 50.0, 1.0, lambda _: None, morse=None,
                                record=tmp_path / "sim.mcap") == 0
    back = read_recording(tmp_path / "sim.mcap")
    assert back.complete and back.count("pose") == 1_000_000_000 // POSE_PERIOD_NS
    assert back.count("sim/status") == back.count("pose")  # a status a frame, a frame a pose period


def _start_up(processes: Processes, path: Path, speed: str) -> subprocess.Popen:
    return processes.vilma("up", "course_30kmh_stanley", "--speed", speed, "--record", str(path),
                           stderr=subprocess.PIPE)


def _wait_for_status(p: subprocess.Popen, t: float) -> None:
    while True:
        line = p.stdout.readline()
        assert line, p.stderr.read()
        if line.startswith("t ") and float(line.split()[1]) >= t:
            return


def test_sigterm_finishes_the_file(tmp_path, processes):
    p = _start_up(processes, tmp_path / "a.mcap", "5")
    _wait_for_status(p, 2.0)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 0 and "Traceback" not in err
    back = read_recording(tmp_path / "a.mcap")
    assert back.complete
    with (tmp_path / "a.mcap").open("rb") as f:
        stats = make_reader(f).get_summary().statistics
    assert stats.message_count == sum(back.count(t) for t in back.topics)


@pytest.fixture(scope="module")
def killed(tmp_path_factory) -> Path:
    """The recording of a ``vilma up`` killed with SIGKILL after 4 s of wall time (chunks flushed every second)."""
    path = tmp_path_factory.mktemp("killed") / "a.mcap"
    with Processes() as processes:
        p = _start_up(processes, path, "1")
        _wait_for_status(p, 4.0)
        p.kill()
        p.communicate(timeout=60)
    assert p.returncode == -signal.SIGKILL
    return path


def test_sigkill_leaves_a_file_readable_up_to_the_last_flushed_chunk(killed):
    back = read_recording(killed)
    assert not back.complete
    pose = back.readings("pose")
    # no hole: every pose period from the first to the last flushed one, and at least 2 s of them
    assert np.all(np.diff(pose.stamp_ns) == POSE_PERIOD_NS)
    assert pose.stamp_ns[-1] - pose.stamp_ns[0] >= 2_000_000_000
    assert np.all(np.isfinite(pose.values))
    assert back.count("tf") == len(pose)


def test_the_report_of_a_killed_recording_says_it_was_cut_short(killed, tmp_path):
    got = report(killed, tmp_path / "rep").metrics
    assert (got["completed"], got["truncated"]) == (False, True)
    assert got["incomplete_reason"].startswith("the recording was cut short; covered")
    assert got["path_progress"] is not None and got["speed_overshoot_pct"] is None  # the course, from its order


def test_up_records_the_scenario_and_the_order_that_starts_its_task(tmp_path):
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    assert programs.up(scenario, 50.0, 1.0, lambda _: None, record=tmp_path / "up.mcap") == 0
    back = read_recording(tmp_path / "up.mcap")
    assert back.attachments["scenario.yaml"].decode() == to_yaml(scenario)
    [order] = back.messages("driver/cmd")
    assert (order.action, order.speed, order.stamp_ns) == ("follow", scenario.task.speed, POSE_PERIOD_NS)
    assert np.array_equal(order.points, scenario.reference_path().xy)  # the driver's first period: its first pose


def test_the_orders_the_driver_took_are_recorded_with_its_time_and_path(tmp_path):
    """A peer's orders carry no time; the driver stamps those it took with its own (a go-to with the line from
    where the car was, a tune with the time of the driver it replaced); a refused order is not recorded."""
    scenario = load_scenario(BUNDLED / "pi_ff_speed_5.yaml")
    bus, sim = LocalBus(), Simulator(scenario.sim)
    sim_node = SimNode(sim, bus)
    drv = DriverNode(Driver(sim.config.vehicle, scenario.driver, step=sim.config.step), bus,
                     step_ns=sim.clock.step_ns)
    recording = BusRecorder(bus, Recorder(tmp_path / "orders.mcap"))
    order = topic("driver/cmd")
    sim_node.frame(sim.advance(2))
    assert bus.request(order, DriverOrder(action="set_speed", speed=5.0)).ok
    for _ in range(50):
        sim_node.frame(sim.advance(2))
    assert not bus.request(order, DriverOrder(action="go_to", x=math.nan, y=0.0, speed=5.0)).ok
    here = sim.state
    assert bus.request(order, DriverOrder(action="go_to", x=here.x + 30.0, y=10.0, speed=5.0)).ok
    assert bus.request(order, DriverOrder(action="tune", speed_controller="vilma_pid")).ok  # a new driver, same time
    recording.close()
    drv.close()
    sim_node.close()
    got = read_recording(tmp_path / "orders.mcap").messages("driver/cmd")
    assert [(o.action, o.stamp_ns) for o in got] == [("set_speed", POSE_PERIOD_NS), ("go_to", 51 * POSE_PERIOD_NS),
                                                     ("tune", 51 * POSE_PERIOD_NS)]
    assert got[1].points == [[here.x, here.y], [here.x + 30.0, 10.0]]


def test_a_programs_recording_writes_the_scenarios_laser_as_a_laser_scan(tmp_path):
    """``vilma up`` / ``vilma sim`` ``--record`` give the recorder the scenario's sensors (the laser's angles)."""
    from tests.record.world_messages import wall_scan

    bus = LocalBus()
    with programs._taps(bus, tmp_path / "up.mcap", None, "vilma up", print,
                        load_scenario(BUNDLED / "course_3d_obstacles.yaml")):  # the default laser: 181 rays
        bus.publish(topic("laser"), wall_scan())
    back = read_recording(tmp_path / "up.mcap")
    assert back.schemas["laser"] == "sensor_msgs/msg/LaserScan" and back.messages("laser") == [wall_scan()]
