"""``vilma report`` from a recording alone, and ``vilma export rosbag2`` read back with rosbags' reader."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from rosbags.rosbag2 import Reader
from rosbags.typesys import get_typestore

from tests.record.world_messages import PERIOD_NS, write_world_recording
from vilma import programs
from vilma.core.geometry import quaternion_from_euler
from vilma.record.reader import read_recording
from vilma.record.report import report, world_counts
from vilma.record.rosbag import STORE, export_rosbag2
from vilma.record.world_schemas import compressed_image
from vilma.scenario import load_scenario
from vilma.scenario.batch import BUNDLED
from vilma.scenario.folder import PLOTS
from vilma.scenario.runner import run
from vilma.scenario.spec import TIMING_KEYS


@pytest.fixture(scope="module")
def finished_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run")
    return run(load_scenario(BUNDLED / "paper_fig11_speed_10.yaml"), out_dir=out), out


def test_report_recomputes_the_runs_scorecard_and_plots(finished_run, tmp_path):
    result, out = finished_run
    again = report(out / "run.mcap", tmp_path / "rep")
    same = {k: v for k, v in result.metrics.items() if k not in TIMING_KEYS}
    assert {k: v for k, v in again.metrics.items() if k not in TIMING_KEYS} == same
    written = json.loads((tmp_path / "rep" / "metrics.json").read_text())
    assert {k: v for k, v in written.items() if k not in TIMING_KEYS} == same
    assert all((tmp_path / "rep" / p).stat().st_size > 0 for p in PLOTS)


def test_report_of_a_live_recording_scores_the_poses(tmp_path):
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    programs.up(scenario, 50.0, 3.0, lambda _: None, record=tmp_path / "up.mcap")
    pose = read_recording(tmp_path / "up.mcap").readings("pose")
    got = report(tmp_path / "up.mcap", tmp_path / "rep").metrics
    assert got["distance_m"] == pytest.approx(np.hypot(*np.diff(pose.values[:, :2], axis=0).T).sum(), rel=1e-12)
    assert got["sim_time_s"] == pose.stamp_ns[-1] * 1e-9


def test_report_cli_writes_beside_the_recording(finished_run):
    _, out = finished_run
    r = subprocess.run([sys.executable, "-m", "vilma.cli", "report", str(out / "run.mcap")], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert (out / "run-report" / "metrics.json").exists()


def test_report_of_a_non_recording_is_one_line(tmp_path):
    (tmp_path / "x.mcap").write_text("hello")
    r = subprocess.run([sys.executable, "-m", "vilma.cli", "report", str(tmp_path / "x.mcap")], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "not a readable MCAP recording" in r.stderr


def _bag(path):
    store = get_typestore(STORE)
    out: dict[str, list] = {}
    with Reader(path) as reader:
        for conn, stamp, data in reader.messages():
            out.setdefault(conn.topic, []).append((stamp, store.deserialize_cdr(data, conn.msgtype), conn.msgtype))
    return out


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


def test_export_refuses_an_existing_folder(finished_run, tmp_path):
    _, out = finished_run
    r = subprocess.run([sys.executable, "-m", "vilma.cli", "export", "rosbag2", str(out / "run.mcap"),
                        str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "exists" in r.stderr


def test_world_sensors_export_as_ros2_images_and_point_clouds(tmp_path):
    sent = write_world_recording(tmp_path / "w.mcap")
    counts = export_rosbag2(tmp_path / "w.mcap", tmp_path / "bag")
    assert {t: counts[t] for t in ("/camera/front_left/compressed", "/camera/front_left/depth", "/laser")} == {
        "/camera/front_left/compressed": 5, "/camera/front_left/depth": 5, "/laser": 5}
    bag = _bag(tmp_path / "bag")
    stamps = [k * PERIOD_NS for k in range(1, 6)]
    rec = read_recording(tmp_path / "w.mcap")

    jpegs = bag["/camera/front_left/compressed"]
    assert {t for _, _, t in jpegs} == {"sensor_msgs/msg/CompressedImage"} and [s for s, _, _ in jpegs] == stamps
    assert [m.data.tobytes() for _, m, _ in jpegs] == [compressed_image(p)[3] for p in rec.payloads(
        "camera/front_left")]  # the recorded JPEG, not compressed twice
    assert {(m.format, m.header.frame_id) for _, m, _ in jpegs} == {("jpeg", "front_left")}

    depth = bag["/camera/front_left/depth"]
    want = [msg for n, msg in sent if n == "camera/front_left/depth"]
    assert {t for _, _, t in depth} == {"sensor_msgs/msg/Image"}
    assert [(m.encoding, m.width, m.height, m.step, m.is_bigendian) for _, m, _ in depth] == [
        ("32FC1", i.width, i.height, i.step, 0) for i in want]
    assert [m.data.tobytes() for _, m, _ in depth] == [i.data for i in want]
    assert [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m, _ in depth] == stamps

    scans = bag["/laser"]
    want = [msg for n, msg in sent if n == "laser"]
    assert {t for _, _, t in scans} == {"sensor_msgs/msg/PointCloud2"}
    cloud = scans[0][1]
    assert [(f.name, f.offset, f.datatype, f.count) for f in cloud.fields] == [
        ("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)]
    assert (cloud.height, cloud.width, cloud.point_step, cloud.row_step) == (1, 79, 12, 79 * 12)
    assert not cloud.is_bigendian and cloud.header.frame_id == "laser"
    assert [m.data.tobytes() for _, m, _ in scans] == [c.points for c in want]


def test_raw_colour_images_export_as_ros2_rgb8_images(tmp_path):
    sent = write_world_recording(tmp_path / "w.mcap", n=2, jpeg_quality=None)
    export_rosbag2(tmp_path / "w.mcap", tmp_path / "bag")
    images = _bag(tmp_path / "bag")["/camera/front_left"]
    want = [msg for n, msg in sent if n == "camera/front_left"]
    assert [(m.encoding, m.step, m.data.tobytes()) for _, m, _ in images] == [("rgb8", i.step, i.data) for i in want]


def test_report_counts_the_world_sensors(tmp_path):
    write_world_recording(tmp_path / "w.mcap")
    r = subprocess.run([sys.executable, "-m", "vilma.cli", "report", str(tmp_path / "w.mcap")], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert "world sensors: camera/front_left 5, camera/front_left/depth 5, laser 5" in r.stdout.splitlines()
    assert world_counts(read_recording(tmp_path / "w.mcap")) == {
        "camera/front_left": 5, "camera/front_left/depth": 5, "laser": 5}
