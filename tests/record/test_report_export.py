"""``vilma report`` from a recording alone, and ``vilma export rosbag2`` read back with rosbags' reader."""

from __future__ import annotations

import dataclasses
import json
import math
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.interfaces import QosDurability, QosReliability
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore

from tests.conftest import free_port
from tests.record.world_messages import (
    FOXGLOVE_FILE,
    LAYERED,
    PERIOD_NS,
    WORLD_SENSORS,
    depth_image,
    wall_scan,
    write_layered_recording,
    write_old_layered_recording,
    write_world_recording,
)
from vilma.app import programs
from vilma.app.batch import BUNDLED
from vilma.app.cli import main
from vilma.app.options import scenario_or_default
from vilma.bus import BoundedQueue, LocalBus, topic
from vilma.bus.zenoh_bus import ZenohBus, ZenohConfig
from vilma.core.geometry import quaternion_from_euler
from vilma.core.messages import ActuatorState, DriverOrder, Pose, SimControl, SimStatus, Velocity
from vilma.record.reader import read_recording
from vilma.record.recorder import Recorder
from vilma.record.report import report, world_counts
from vilma.record.rosbag import STORE, export_rosbag2
from vilma.record.run import record_run
from vilma.record.world_schemas import compressed_image
from vilma.scenario import load_scenario
from vilma.scenario.folder import PLOTS
from vilma.scenario.metrics import WATCHDOG_STOP
from vilma.scenario.result import OnReadings
from vilma.scenario.runner import Interrupted, run
from vilma.scenario.spec import SCORECARD_KEYS, TIMING_KEYS
from vilma.sensors import Readings


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    return record_run(load_scenario(BUNDLED / "paper_fig11_speed_10.yaml"), out), out


GO_TO = "task: {go_to: [40, 10], speed: 5}\nduration: 30\n"
"""A go-to task (none is bundled): its path, the line from where the car was, is only in the recording."""


@pytest.fixture(scope="module", params=["pi_ff_speed_5", "course_30kmh_stanley", "go_to"])
def scored_run(request, tmp_path_factory):
    """A run of a speed, a path and a go-to task: its folder and its metrics.json."""
    out = tmp_path_factory.mktemp(request.param)
    if request.param == "go_to":
        (out / "go_to.yaml").write_text(GO_TO)
        scenario = load_scenario(out / "go_to.yaml")
    else:
        scenario = load_scenario(BUNDLED / f"{request.param}.yaml")
    record_run(scenario, out / "run")
    return out / "run", json.loads((out / "run" / "metrics.json").read_text())


def test_report_of_a_run_gives_its_metrics_json(scored_run, tmp_path):
    out, ran = scored_run
    rec = read_recording(out / "run.mcap")
    got = report(rec, tmp_path / "rep")
    same = [k for k in SCORECARD_KEYS if k not in TIMING_KEYS]
    assert {k: got.metrics[k] for k in same} == {k: ran[k] for k in same}
    assert got.failures == rec.meta("run")["failures"]
    # the loop's own time is the recording's, realtime_factor made from it as the run did; a report runs nothing
    for k in ("loop_wall_time_s", "realtime_factor", "controller_time_per_step_us"):
        assert got.metrics[k] == ran[k], k
    assert got.metrics["load_time_s"] == rec.meta("scorecard")["load_time_s"] and got.metrics["wall_time_s"] is None
    assert json.loads((tmp_path / "rep" / "metrics.json").read_text()) == {**got.metrics, "segments": [
        {"start_s": rec.drive_log()[0, 0], "began": "start", **{k: ran[k] for k in same}}]}
    assert all((tmp_path / "rep" / p).stat().st_size > 0 for p in PLOTS)


def test_report_of_an_interrupted_run_is_truncated(tmp_path):
    """Ctrl-C: the run's recording is finished, without the run's metadata (when the task began, how it ended)."""
    periods = iter(range(100))

    def ctrl_c(_readings) -> None:
        if next(periods, None) is None:
            raise KeyboardInterrupt

    with pytest.raises(Interrupted):
        record_run(load_scenario(BUNDLED / "pi_ff_speed_5.yaml"), tmp_path, compiled=False,
                   observers=[OnReadings(ctrl_c)])
    rec = read_recording(tmp_path / "run.mcap")
    assert rec.complete and "run" not in rec.metadata
    got = report(rec, tmp_path / "rep").metrics
    assert (got["completed"], got["truncated"]) == (False, True)
    assert got["incomplete_reason"].startswith("the recording was cut short; ended at ")  # 2 s in: not at 5 m/s
    assert got["distance_m"] == pytest.approx(np.hypot(*np.diff(rec.drive_log()[:, 1:3], axis=0).T).sum(),
                                              rel=1e-12)


def _up(path: Path, name: str, duration: float) -> Path:
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "up", name, "--speed", "50", "--duration", str(duration),
                        "--record", str(path)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return path


@pytest.mark.slow
@pytest.mark.parametrize(("name", "duration"), [("course_30kmh_stanley", 20.0), ("pi_ff_speed_5", 10.0)])
def test_report_of_vilma_up_gives_the_figures_of_vilma_run(tmp_path, name, duration):
    """The nodes drive as the runner's loop does (tests/bus/test_nodes.py) and a pose is recorded each control
    period, so the report of ``vilma up --record`` is the scorecard of ``vilma run`` (to rounding): the task read
    from the recording, a path task without speed-step keys, a speed task without path keys."""
    got = report(_up(tmp_path / "up.mcap", name, duration), tmp_path / "rep").metrics
    want = run(dataclasses.replace(load_scenario(BUNDLED / f"{name}.yaml"), duration=duration)).metrics
    for k in SCORECARD_KEYS:
        if k not in TIMING_KEYS:
            assert got[k] == (pytest.approx(want[k], rel=1e-9) if isinstance(want[k], float) else want[k]), k
    assert all(got[k] is None for k in TIMING_KEYS)  # a live recording holds no run's timing


def _stop(p: subprocess.Popen) -> None:
    p.send_signal(signal.SIGINT)
    out, _ = p.communicate(timeout=60)
    assert p.returncode == 0, out


def _stretches(stamps: np.ndarray, *values: np.ndarray) -> list[list[np.ndarray]]:
    """``values`` split where the stamps go back (the simulator's clock after a reset)."""
    cut = np.flatnonzero(np.diff(stamps) < 0) + 1
    return [np.split(v, cut) for v in (stamps * 1e-9, *values)]


@pytest.mark.slow
def test_report_of_vilma_sim_scores_each_segment_between_resets(tmp_path, processes):
    """``vilma sim --record`` and ``vilma drive`` holding 5 m/s (a speed task: straight along x) on Zenoh; the
    simulator is reset through the bus once the car is 40 m on, and stopped 30 m after the start again. Each
    segment's distance is its poses' last x minus the first; the jump back to the start is driven by nobody."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sim = processes.vilma("sim", "pi_ff_speed_5", "--listen", endpoint, "--no-morse", "--speed", "10",
                          "--record", str(tmp_path / "sim.mcap"))
    bus = ZenohBus(ZenohConfig(listen=("tcp/127.0.0.1:0",), connect=(endpoint,)))
    try:
        poses = BoundedQueue(bus, topic("pose"), maxsize=100_000)
        assert poses.wait(lambda _: True, 60), "no pose from vilma sim"
        drive = processes.vilma("drive", "pi_ff_speed_5", "--connect", endpoint)
        assert poses.wait(lambda p: p.x > 40.0, 120), "the car did not drive 40 m"
        assert bus.request(topic("sim/cmd"), SimControl(action="reset"), timeout=10).ok
        assert poses.wait(lambda p: p.x < 1.0, 60), "the car was not put back"
        assert poses.wait(lambda p: p.x > 30.0, 120), "the car did not drive again"
        _stop(sim)
        _stop(drive)
    finally:
        bus.close()
    rec = read_recording(tmp_path / "sim.mcap")
    assert [(o.action, o.speed) for o in rec.messages("driver/cmd")] == [("set_speed", 5.0)]  # the drive's task
    pose, v = rec.readings("pose"), rec.readings("velocity")
    assert np.all(pose.field("y") == 0.0)
    t, x = _stretches(pose.stamp_ns, pose.field("x"))
    assert len(x) == 2 and abs(x[1][0] - x[0][0]) < 0.01  # one reset: back at the start (a frame from rest)

    got = report(rec, tmp_path / "rep")
    assert [s["began"] for s in got.segments] == ["start", "reset"]
    assert [s["distance_m"] for s in got.segments] == [pytest.approx(a[-1] - a[0], rel=1e-9) for a in x]
    assert got.metrics["distance_m"] == pytest.approx(sum(a[-1] - a[0] for a in x), rel=1e-9)
    assert got.metrics["sim_time_s"] == pytest.approx(t[0][-1] + t[1][-1], abs=1e-9)
    last = [k for k in SCORECARD_KEYS if k not in ("distance_m", "sim_time_s", *TIMING_KEYS)]
    assert {k: got.metrics[k] for k in last} == {k: got.segments[1][k] for k in last}
    assert got.segments[0]["completed"] is True  # 40 m on: long at its 5 m/s
    # stopped 30 m after the start again, maybe still settling: done only if at its speed by then
    assert got.segments[1]["completed"] is (got.segments[1]["speed_settling_time_2pct_s"] is not None)
    # after the reset the car starts from rest again: its speed passes 90 % of 5 m/s between two velocity samples
    at, speed = (a[1] for a in _stretches(v.stamp_ns, v.field("vx")))
    first = np.flatnonzero(speed >= 4.5)[0]
    assert at[first - 1] - t[1][0] <= got.segments[1]["speed_rise_time_90_s"] <= at[first] - t[1][0]


def test_report_cli_writes_beside_the_recording(finished_run):
    _, out = finished_run
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "report", str(out / "run.mcap")], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert (out / "run-report" / "metrics.json").exists()


def test_quiet_report_prints_only_what_failed(tmp_path, capsys):
    strict = tmp_path / "strict.yaml"
    # 10 m/s in 2 s
    strict.write_text("task: {speed: 10}\nduration: 2\nexpect: {completed: false, speed_rise_time_90_s: {max: 1.0}}\n")
    assert main(["run", str(strict), "--out", str(tmp_path / "run"), "-q"]) == 1
    capsys.readouterr()
    assert main(["report", str(tmp_path / "run"), "--out", str(tmp_path / "rep"), "-q"]) == 1
    printed = capsys.readouterr()
    assert printed.out == "" and printed.err == "FAIL speed_rise_time_90_s: None is outside max 1\n"
    assert (tmp_path / "rep" / "metrics.json").exists() and (tmp_path / "rep" / "speed.png").exists()


def test_report_of_a_non_recording_is_one_line(tmp_path):
    (tmp_path / "x.mcap").write_text("hello")
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "report", str(tmp_path / "x.mcap")], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "not a readable MCAP recording" in r.stderr


def _bag(path):
    store = get_typestore(STORE)
    out: dict[str, list] = {}
    with Reader(path) as reader:
        for conn, stamp, data in reader.messages():
            out.setdefault(conn.topic, []).append((stamp, store.deserialize_cdr(data, conn.msgtype), conn.msgtype))
    return out


def test_rosbag2_export_gives_the_objects_as_markers_read_back(tmp_path):
    """Each object of the objects sensor's lists: a cube of its id, pose and size, and an arrow of its speed."""
    from tests.scenario.test_reactive_traffic import _scenario

    sc = dataclasses.replace(_scenario(tmp_path, "objects: {range: 200}"), duration=1.0)
    record_run(sc, tmp_path / "run")
    lists = read_recording(tmp_path / "run" / "run.mcap").messages("objects")
    assert sum(len(ol.objects) for ol in lists) > 0
    counts = export_rosbag2(tmp_path / "run" / "run.mcap", tmp_path / "bag")
    got = _bag(tmp_path / "bag")["/objects"]
    assert counts["/objects"] == len(got) == len(lists)
    for (stamp, msg, kind), ol in zip(got, lists, strict=True):
        assert kind == "visualization_msgs/msg/MarkerArray" and stamp == ol.stamp_ns
        clear, *markers = msg.markers
        assert clear.action == clear.DELETEALL  # the last list's markers go
        assert [(mk.ns, mk.id) for mk in markers] == [(ns, o.id) for o in ol.objects
                                                      for ns in ("objects", "objects/velocity")]
        for o, cube, arrow in zip(ol.objects, markers[::2], markers[1::2], strict=True):
            assert (cube.type, arrow.type) == (cube.CUBE, arrow.ARROW)
            for mk in (cube, arrow):
                q = mk.pose.orientation
                assert mk.header.frame_id == "map" and (mk.pose.position.x, mk.pose.position.y) == (o.x, o.y)
                assert 2 * math.atan2(q.z, q.w) == pytest.approx(o.yaw, abs=1e-12)
            assert (cube.scale.x, cube.scale.y) == (o.length, o.width) and arrow.scale.x == o.speed


def test_rosbag2_export_reads_back_with_values_and_timestamps(finished_run, tmp_path):
    _, out = finished_run
    rec = read_recording(out / "run.mcap")
    counts = export_rosbag2(out / "run.mcap", tmp_path / "bag")
    bag = _bag(tmp_path / "bag")
    assert {t: len(v) for t, v in bag.items()} == counts

    pose = rec.readings("pose")
    got = bag["/pose"]
    assert {t for _, _, t in got} == {"geometry_msgs/msg/PoseStamped"}
    assert [s for s, _, _ in got] == pose.stamp_ns.tolist()
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m, _ in got] == pose.stamp_ns.tolist()
    assert [(m.pose.position.x, m.pose.position.y) for _, m, _ in got] == [tuple(v) for v in pose.values[:, :2]]
    q = np.column_stack(quaternion_from_euler(*pose.values[:, 3:6].T))
    assert np.array_equal([[m.pose.orientation.x, m.pose.orientation.y, m.pose.orientation.z, m.pose.orientation.w]
                           for _, m, _ in got], q)

    vel = rec.readings("velocity")
    assert [m.twist.linear.x for _, m, _ in bag["/velocity"]] == vel.field("vx_world").tolist()
    assert [m.twist.angular.z for _, m, _ in bag["/velocity"]] == vel.field("wz").tolist()
    gps = rec.readings("gps")
    assert [(m.latitude, m.longitude, m.altitude) for _, m, _ in bag["/gps"]] == [tuple(v) for v in gps.values[:, :3]]
    imu = rec.readings("imu")
    assert [m.linear_acceleration.z for _, m, _ in bag["/imu"]] == imu.field("az").tolist()
    wheels = rec.readings("wheel_speed")
    assert np.array_equal([m.data for _, m, _ in bag["/wheelspeed"]], wheels.values)
    assert bag["/wheelspeed"][0][1].layout.dim[0].label.startswith("fl,fr,rl,rr")
    odo = rec.readings("odometry")
    assert [m.twist.twist.linear.x for _, m, _ in bag["/odom"]] == odo.field("speed").tolist()
    assert [m.transforms[0].child_frame_id for _, m, _ in bag["/tf"]] == ["vilma"] * len(pose)
    assert np.array_equal([m.data for _, m, _ in bag["/drive_log"]], rec.drive_log(), equal_nan=True)
    assert "/tf_static" not in bag  # a run without cameras or laser: no sensor frames


def test_export_refuses_an_existing_folder(finished_run, tmp_path):
    _, out = finished_run
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "export", "rosbag2", str(out / "run.mcap"),
                        str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "exists" in r.stderr


def test_world_sensors_export_as_ros2_images_scans_and_point_clouds(tmp_path):
    sent = write_world_recording(tmp_path / "w.mcap", jpeg_quality=90)
    counts = export_rosbag2(tmp_path / "w.mcap", tmp_path / "bag")
    topics = {"/camera/front_left/compressed": "sensor_msgs/msg/CompressedImage",
              "/camera/front_left/camera_info": "sensor_msgs/msg/CameraInfo",
              "/camera/front_left/depth": "sensor_msgs/msg/Image", "/laser": "sensor_msgs/msg/LaserScan",
              "/laser/points": "sensor_msgs/msg/PointCloud2"}
    assert {t: counts[t] for t in topics} == dict.fromkeys(topics, 5)
    bag = _bag(tmp_path / "bag")
    stamps = [k * PERIOD_NS for k in range(1, 6)]
    for ros_topic, ros_type in topics.items():
        assert [(s, t) for s, _, t in bag[ros_topic]] == [(s, ros_type) for s in stamps], ros_topic
        assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m, _ in bag[ros_topic]] == stamps

    jpegs = bag["/camera/front_left/compressed"]
    assert {(m.format, m.header.frame_id, m.data[:2].tobytes()) for _, m, _ in jpegs} == {
        ("jpeg", "front_left", b"\xff\xd8")}  # a JPEG file (start of image)
    assert {m.k[0] for _, m, _ in bag["/camera/front_left/camera_info"]} == {60 / math.tan(math.radians(30))}

    depth = bag["/camera/front_left/depth"]
    want = [msg for n, msg in sent if n == "camera/front_left/depth"]
    assert [(m.encoding, m.width, m.height, m.step, m.is_bigendian) for _, m, _ in depth] == [
        ("32FC1", i.width, i.height, i.step, 0) for i in want]
    assert [m.data.tobytes() for _, m, _ in depth] == [i.data for i in want]

    want = [msg for n, msg in sent if n == "laser"]
    assert [m.ranges.tobytes() for _, m, _ in bag["/laser"]] == [c.ranges for c in want]
    assert [m.data.tobytes() for _, m, _ in bag["/laser/points"]] == [c.points for c in want]


def test_a_multi_layer_laser_exports_its_organized_point_cloud2_as_recorded(tmp_path):
    """``/laser`` the recorded PointCloud2's bytes (a row a layer), no ``/laser/points``; and a LaserScan
    recorded before, with its points, as it was."""
    sent = write_layered_recording(tmp_path / "l.mcap")
    rec = read_recording(tmp_path / "l.mcap")
    counts = export_rosbag2(rec, tmp_path / "bag")
    assert counts == {"/tf_static": 1, "/laser": len(sent)}
    with Reader(tmp_path / "bag") as reader:
        raw = [(c.topic, c.msgtype, stamp, bytes(data)) for c, stamp, data in reader.messages()
               if c.topic == "/laser"]
    assert raw == [("/laser", "sensor_msgs/msg/PointCloud2", s.stamp_ns, p)
                   for s, p in zip(sent, rec.payloads("laser"), strict=True)]
    clouds = [m for _, m, _ in _bag(tmp_path / "bag")["/laser"]]
    assert {(c.height, c.width) for c in clouds} == {(len(LAYERED.layers), len(LAYERED.bearings))}
    assert world_counts(rec) == {"laser": len(sent)}

    old = write_old_layered_recording(tmp_path / "old.mcap")
    counts = export_rosbag2(tmp_path / "old.mcap", tmp_path / "old_bag")
    assert counts == {"/laser": len(old), "/laser/points": len(old)}
    bag = _bag(tmp_path / "old_bag")
    assert [m.ranges.tobytes() for _, m, _ in bag["/laser"]] == [c.ranges for c in old]
    assert [m.data.tobytes() for _, m, _ in bag["/laser/points"]] == [c.points for c in old]


def test_the_sensor_mounts_export_as_one_latched_tf_static_message(tmp_path):
    """``/tf_static``: a ``tf2_msgs/msg/TFMessage`` at stamp 0 with a transform a sensor, offered transient local
    (durability 1 in ``metadata.yaml``), as ``ros2 bag`` records tf2's static broadcaster."""
    write_world_recording(tmp_path / "w.mcap")
    assert export_rosbag2(tmp_path / "w.mcap", tmp_path / "bag")["/tf_static"] == 1
    [(stamp, msg, kind)] = _bag(tmp_path / "bag")["/tf_static"]
    assert (stamp, kind) == (0, "tf2_msgs/msg/TFMessage")
    camera, laser = WORLD_SENSORS
    assert [(t.header.frame_id, t.child_frame_id, t.header.stamp.sec, t.header.stamp.nanosec)
            for t in msg.transforms] == [("vilma", camera.name, 0, 0), ("vilma", laser.name, 0, 0)]
    for t, sensor in zip(msg.transforms, WORLD_SENSORS, strict=True):
        v = t.transform.translation
        assert (v.x, v.y, v.z) == sensor.position
    q = msg.transforms[0].transform.rotation
    assert np.allclose((q.x, q.y, q.z, q.w), (-0.5, 0.5, -0.5, 0.5))  # pitch, yaw 0: the optical frame
    with Reader(tmp_path / "bag") as reader:
        [qos] = next(c for c in reader.connections if c.topic == "/tf_static").ext.offered_qos_profiles
        assert (qos.durability, qos.reliability) == (QosDurability.TRANSIENT_LOCAL, QosReliability.RELIABLE)
        others = [c.ext.offered_qos_profiles for c in reader.connections if c.topic != "/tf_static"]
        assert others == [[]] * len(others)
    meta = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    [info] = [t["topic_metadata"] for t in meta["topics_with_message_count"]
              if t["topic_metadata"]["name"] == "/tf_static"]
    [profile] = yaml.safe_load(info["offered_qos_profiles"])  # a YAML text in bag version 8
    assert (profile["durability"], profile["reliability"]) == (1, 1)  # rmw's transient local, reliable


def test_a_foxglove_json_recording_exports_its_images_and_point_clouds(tmp_path):
    """``data/foxglove_world.mcap`` (before the ROS 2 types): the recorded JPEG, the depth, the hits."""
    counts = export_rosbag2(FOXGLOVE_FILE, tmp_path / "bag")
    assert counts == {"/pose": 10, "/velocity": 10, "/actuators": 10, "/tf": 10, "/camera/front_left/compressed": 2,
                      "/camera/front_left/depth": 2, "/laser": 2}
    bag = _bag(tmp_path / "bag")
    rec = read_recording(FOXGLOVE_FILE)
    jpegs = bag["/camera/front_left/compressed"]
    assert [m.data.tobytes() for _, m, _ in jpegs] == [compressed_image(p)[3] for p in rec.payloads(
        "camera/front_left")]  # the recorded JPEG, not compressed twice
    stamps = [PERIOD_NS, 2 * PERIOD_NS]
    assert [m.data.tobytes() for _, m, _ in bag["/camera/front_left/depth"]] == [depth_image(t).data for t in stamps]
    scans = bag["/laser"]
    assert {t for _, _, t in scans} == {"sensor_msgs/msg/PointCloud2"}
    cloud = scans[0][1]
    assert [(f.name, f.offset, f.datatype, f.count) for f in cloud.fields] == [
        ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)]
    assert (cloud.height, cloud.width, cloud.point_step, cloud.row_step) == (1, 79, 12, 79 * 12)
    assert not cloud.is_bigendian and cloud.header.frame_id == "laser"
    assert [m.data.tobytes() for _, m, _ in scans] == [wall_scan(t).points for t in stamps]


def test_raw_colour_images_export_as_ros2_rgb8_images(tmp_path):
    sent = write_world_recording(tmp_path / "w.mcap", n=2)
    export_rosbag2(tmp_path / "w.mcap", tmp_path / "bag")
    images = _bag(tmp_path / "bag")["/camera/front_left"]
    want = [msg for n, msg in sent if n == "camera/front_left"]
    assert [(m.encoding, m.step, m.data.tobytes()) for _, m, _ in images] == [("rgb8", i.step, i.data) for i in want]


def test_report_counts_the_world_sensors(tmp_path):
    write_world_recording(tmp_path / "w.mcap")
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "report", str(tmp_path / "w.mcap")], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "world sensors: camera/front_left 5, camera/front_left/depth 5, laser 5" in r.stdout.splitlines()
    assert world_counts(read_recording(tmp_path / "w.mcap")) == {
        "camera/front_left": 5, "camera/front_left/depth": 5, "laser": 5}


@pytest.mark.slow
@pytest.mark.parametrize("name", ["course_30kmh_stanley", "pi_ff_speed_5"])
def test_without_the_drivers_orders_the_task_is_its_mode_and_the_scenarios(tmp_path, name):
    """A recording whose driver did not publish the orders it took: the task is told by the driver's mode, a
    speed task at its target, a path the scenario's: the same figures as from the orders."""
    programs.up(load_scenario(BUNDLED / f"{name}.yaml"), 50.0, 6.0, lambda _: None, record=tmp_path / "up.mcap")
    rec = read_recording(tmp_path / "up.mcap")
    want = report(rec, tmp_path / "rep").metrics
    del rec.raw["driver/cmd"], rec.epochs["driver/cmd"]
    assert report(rec, tmp_path / "rep2").metrics == want


TASK_KEYS = ("end_error_m", "path_progress", "waypoints_skipped", "lateral_error_rms_m", "lateral_error_max_m",
             "lateral_error_p95_m", "heading_error_rms_rad", "speed_rise_time_90_s", "speed_overshoot_pct",
             "speed_settling_time_2pct_s", "speed_steady_state_error_mps")
"""The keys of a path task and of a speed step."""


def test_without_a_driver_nothing_of_a_task_is_scored(tmp_path):
    """``vilma sim`` recorded alone: no order, no driver status; its scenario's task (``vilma sim``'s idle
    default) is not the drive's."""
    programs.sim_program(scenario_or_default(None), LocalBus(), 50.0, 2.0, lambda _: None, morse=None,
                         record=tmp_path / "sim.mcap")
    got = report(tmp_path / "sim.mcap", tmp_path / "rep")
    assert got.metrics["completed"] is None and got.failures == []
    assert got.metrics["incomplete_reason"] == "the recording holds neither the driver's orders nor its status"
    assert all(got.metrics[k] is None for k in TASK_KEYS)
    assert got.metrics["distance_m"] == 0.0  # nobody drove


FRAME_NS = 20_000_000
"""The pose period of the synthetic recordings [ns] (50 Hz)."""


def test_a_pose_jump_without_a_clock_reset_starts_a_segment_and_a_tripped_watchdog_ends_the_task(tmp_path):
    """A car at 1 m/s along x for 2 s, put back to x = 0 with the clock going on (a reset that keeps the time),
    2 s more, the watchdog tripped at the end: the jump (2 m in a frame at 1 m/s) is no distance, and the last
    segment's task (hold 1 m/s) was not completed."""
    stamps = np.arange(1, 201, dtype=np.int64) * FRAME_NS
    x = np.where(stamps <= 100 * FRAME_NS, stamps, stamps - 100 * FRAME_NS) * 1e-9  # [m] at 1 m/s
    pose, velocity = np.zeros((len(stamps), 6)), np.zeros((len(stamps), 9))
    pose[:, 0], velocity[:, [0, 3]] = x, 1.0
    rec = Recorder(tmp_path / "jump.mcap")
    rec.add_readings({"pose": Readings("pose", Pose, stamps, pose),
                      "velocity": Readings("velocity", Velocity, stamps, velocity),
                      "actuators": Readings("actuators", ActuatorState, stamps, np.zeros((len(stamps), 3)))})
    rec.add_message("driver/cmd", DriverOrder(stamp_ns=FRAME_NS, action="set_speed", speed=1.0))
    for t in stamps:
        rec.add_message("sim/status", SimStatus(stamp_ns=int(t), watchdog_tripped=bool(t == stamps[-1])))
    rec.close()
    got = report(tmp_path / "jump.mcap", tmp_path / "rep")
    halves = np.split(x, [100])
    assert [(s["began"], s["start_s"]) for s in got.segments] == [("start", 0.02), ("jump", 2.02)]
    assert [s["distance_m"] for s in got.segments] == [pytest.approx(h[-1] - h[0], rel=1e-12) for h in halves]
    assert got.metrics["sim_time_s"] == 4.0  # one clock: no time added by the jump
    assert got.segments[0]["completed"] is True
    assert (got.metrics["completed"], got.metrics["incomplete_reason"]) == (False, WATCHDOG_STOP)
