"""Recording camera images and laser scans from a bus, read back by vilma and by the mcap library."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from tests.record.world_messages import (
    FOXGLOVE_FILE,
    LAYERED,
    PERIOD_NS,
    SQUARE,
    WORLD_SENSORS,
    WORLD_TOPICS,
    depth_image,
    red_square,
    wall_rays,
    wall_scan,
    world_at,
    write_layered_recording,
    write_old_layered_recording,
    write_world_recording,
)
from vilma.app.batch import BUNDLED
from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core.messages import Image, PointCloud, SimStatus
from vilma.plant3d.camera import CameraParams
from vilma.record.reader import read_recording
from vilma.record.recorder import BusRecorder, Recorder
from vilma.record.run_recorder import RunRecorder
from vilma.record.sensor_frames import decode_frame
from vilma.record.world_cdr import CAMERA_INFO, COMPRESSED_IMAGE, IMAGE, LASER_SCAN, POINT_CLOUD2
from vilma.scenario import load_scenario
from vilma.scenario.drive_log import DriveLog
from vilma.sim import Simulator


def _publish_world(bus: LocalBus, n: int) -> list[tuple[str, object]]:
    sent = [c for k in range(1, n + 1) for c in world_at(k * PERIOD_NS)]
    for name, msg in sent:
        bus.publish(topic(name), msg)
    return sent


def test_a_bus_recording_reads_back_images_and_scans(tmp_path):
    bus = LocalBus()
    recording = BusRecorder(bus, Recorder(tmp_path / "w.mcap", world_sensors=WORLD_SENSORS), world_topics=WORLD_TOPICS)
    sent = _publish_world(bus, 5)
    recording.close()

    back = read_recording(tmp_path / "w.mcap")
    assert back.complete and sorted(back.world_topics) == sorted(WORLD_TOPICS)
    written = {"camera/front_left": IMAGE, "camera/front_left/camera_info": CAMERA_INFO,
               "camera/front_left/depth": IMAGE, "laser": LASER_SCAN, "laser/points": POINT_CLOUD2}
    assert {n: back.schemas[n] for n in written} == written
    assert back.messages("laser") == [m for n, m in sent if n == "laser"]
    for name in ("camera/front_left", "camera/front_left/depth"):
        assert back.messages(name) == [m for n, m in sent if n == name]

    with (tmp_path / "w.mcap").open("rb") as f:  # as Foxglove's own decoder reads the file's ROS 2 schemas
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        by_topic = {c.topic: c for c in summary.channels.values()}
        for name in written:
            ch = by_topic[f"vilma/vilma/{name}"]
            assert ch.message_encoding == "cdr" and summary.schemas[ch.schema_id].encoding == "ros2msg"
            assert summary.statistics.channel_message_counts[ch.id] == 5
        first = {}
        for _, ch, _, msg in reader.iter_decoded_messages():
            first.setdefault(ch.topic.removeprefix("vilma/vilma/"), msg)
    scan, points, info = first["laser"], first["laser/points"], first["camera/front_left/camera_info"]
    angles, ranges = wall_rays()
    assert (scan.header.frame_id, scan.angle_min, scan.angle_max) == ("laser", np.float32(angles[0]),
                                                                      np.float32(angles[-1]))
    assert scan.angle_increment == np.float32(math.radians(1)) and (scan.range_min, scan.range_max) == (
        np.float32(0.1), np.float32(30.0))  # LaserParams' defaults
    assert np.array_equal(scan.ranges, ranges) and len(scan.intensities) == 0
    assert [(f.name, f.offset, f.datatype, f.count) for f in points.fields] == [("x", 0, 7, 1), ("y", 4, 7, 1),
                                                                                 ("z", 8, 7, 1)]
    assert bytes(points.data) == wall_scan(PERIOD_NS).points and points.width == np.isfinite(ranges).sum()
    f_px = 60 / math.tan(math.radians(30))  # half the 120 px height over tan(half of 60 deg)
    assert (info.header.frame_id, info.width, info.height, info.distortion_model) == ("front_left", 160, 120,
                                                                                       "plumb_bob")
    assert np.allclose(info.k, [f_px, 0, 79.5, 0, f_px, 59.5, 0, 0, 1]) and list(info.d) == [0.0] * 5
    assert np.allclose(info.p, [f_px, 0, 79.5, 0, 0, f_px, 59.5, 0, 0, 0, 1, 0])


def test_the_world_sensors_mounts_are_static_transforms_from_the_car_at_sim_start(tmp_path):
    """One ``foxglove_msgs/msg/FrameTransform`` a sensor on ``tf_static`` at log time 0, as Foxglove reads it."""
    write_world_recording(tmp_path / "w.mcap")
    camera, laser = WORLD_SENSORS
    with (tmp_path / "w.mcap").open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        ch = next(c for c in summary.channels.values() if c.topic == "vilma/vilma/tf_static")
        schema = summary.schemas[ch.schema_id]
        assert (schema.name, schema.encoding, ch.message_encoding) == ("foxglove_msgs/msg/FrameTransform", "ros2msg",
                                                                       "cdr")
        tf = next(c for c in summary.channels.values() if c.topic == "vilma/vilma/tf")
        assert tf.schema_id == ch.schema_id  # the same schema as the car's frame in the map
        got = [(m.log_time, m.publish_time, msg) for _, _, m, msg in reader.iter_decoded_messages(
            topics=["vilma/vilma/tf_static"])]
    assert [(lt, pt, t.timestamp.sec, t.timestamp.nanosec) for lt, pt, t in got] == [(0, 0, 0, 0)] * 2
    frames = {t.child_frame_id: t for _, _, t in got}
    assert set(frames) == {camera.name, laser.name} and {t.parent_frame_id for t in frames.values()} == {"vilma"}
    for sensor in WORLD_SENSORS:
        t = frames[sensor.name].translation
        assert (t.x, t.y, t.z) == sensor.position
    q = frames[laser.name].rotation  # yaw 0: the car's axes
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
    q = frames[camera.name].rotation  # pitch and yaw 0: the optical frame's z forward, x right, y down
    assert np.allclose((q.x, q.y, q.z, q.w), (-0.5, 0.5, -0.5, 0.5))

    back = read_recording(tmp_path / "w.mcap")  # read as before: tf_static is no world topic nor a bus one
    assert back.count("tf_static") == 2 and sorted(back.world_topics) == sorted(WORLD_TOPICS)


def test_a_recording_without_world_sensors_has_no_static_transforms(tmp_path):
    Recorder(tmp_path / "a.mcap").close()
    Recorder(tmp_path / "b.mcap", car="front", world_sensors=(CameraParams(name="front"),)).close()
    for name in ("a", "b"):  # none, and a camera named as the car (its frame is the car's own)
        with (tmp_path / f"{name}.mcap").open("rb") as f:
            assert not [c.topic for c in make_reader(f).get_summary().channels.values() if "tf_static" in c.topic]


def test_a_recording_of_foxglove_json_images_and_scans_still_reads():
    back = read_recording(FOXGLOVE_FILE)
    assert back.schemas["laser"] == "foxglove.PointCloud" and sorted(back.world_topics) == sorted(WORLD_TOPICS)
    stamps = [PERIOD_NS, 2 * PERIOD_NS]
    assert back.messages("laser") == [wall_scan(t) for t in stamps]
    assert back.messages("camera/front_left/depth") == [depth_image(t) for t in stamps]
    assert [(c.stamp_ns, c.width, c.height) for c in back.messages("camera/front_left")] == [
        (t, 160, 120) for t in stamps]


def test_raw_colour_images_read_back_exactly_and_jpeg_ones_within_tolerance(tmp_path):
    rec = Recorder(tmp_path / "raw.mcap")
    img = red_square(pad=3)
    rec.add_message("camera/rear", img)
    rec.close()
    back = read_recording(tmp_path / "raw.mcap")
    assert back.schemas["camera/rear"] == IMAGE and back.messages("camera/rear") == [img]

    write_world_recording(tmp_path / "jpeg.mcap", jpeg_quality=90)
    back = read_recording(tmp_path / "jpeg.mcap")
    colour = back.messages("camera/front_left")
    assert back.schemas["camera/front_left"] == COMPRESSED_IMAGE
    assert [c.stamp_ns for c in colour] == [k * PERIOD_NS for k in range(1, 6)]
    x, y, w, h = SQUARE
    for c in colour:
        px = np.frombuffer(c.data, np.uint8).reshape(c.height, c.width, 3).astype(int)
        assert np.abs(px[y + 8:y + h - 8, x + 8:x + w - 8] - (255, 0, 0)).max() <= 12  # lossy JPEG


def test_malformed_messages_are_dropped_with_one_warning_a_topic(tmp_path, caplog):
    bus = LocalBus()
    recording = BusRecorder(bus, Recorder(tmp_path / "bad.mcap"), world_topics=WORLD_TOPICS)
    good = red_square()
    torn = Image(1, "front_left", good.width, good.height, "rgb8", good.step, good.data[:-1])
    scan = wall_scan()
    with caplog.at_level(logging.DEBUG, logger="vilma.record"):
        for _ in range(3):
            bus.publish(topic("camera/front_left"), torn)
        bus.publish(topic("laser"), PointCloud(1, "laser", scan.points[:-12], scan.ranges))
        bus.publish(topic("camera/front_left"), good)
    recording.close()
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == ["recording camera/front_left: 57599 bytes of data, not height 120 x step 480 = 57600; "
                        "message dropped", "recording laser: 78 points for 79 finite ranges; message dropped"]
    assert recording.recorder.dropped == {"camera/front_left": 3, "laser": 1}
    back = read_recording(tmp_path / "bad.mcap")
    assert back.count("camera/front_left") == 1 and back.count("laser") == 0


def test_bad_world_topics_and_quality_are_refused_at_once(tmp_path):
    rec = Recorder(tmp_path / "a.mcap")
    with pytest.raises(ValueError, match="'pose' is not a camera or laser topic"):
        BusRecorder(LocalBus(), rec, world_topics=("pose",))
    rec.close()
    with pytest.raises(ValueError, match="JPEG quality"):
        Recorder(tmp_path / "b.mcap", jpeg_quality=100)


def test_a_run_records_the_captures_it_is_handed(tmp_path):
    """With the scenario's sensors: the default laser (:func:`wall_scan`'s rays), a 320x240 stereo pair."""
    scenario = load_scenario(BUNDLED / "course_3d_obstacles.yaml")
    run = RunRecorder(tmp_path / "run.mcap", scenario)
    with Simulator() as sim:  # any simulator: the scenario has no road, whose traffic the recorder would read
        run.started(sim, DriveLog(capacity=10))
    depth = depth_image(PERIOD_NS, 320, 240)
    run.add_captures([("laser", wall_scan(PERIOD_NS)), ("camera/front_left/depth", depth)])
    run.failed(interrupted=False)
    back = read_recording(tmp_path / "run.mcap")
    assert back.messages("laser") == [wall_scan(PERIOD_NS)] and back.schemas["laser"] == LASER_SCAN
    assert back.messages("camera/front_left/depth") == [depth]
    frames = [decode_frame(p)[1] for p in back.payloads("tf_static")]  # written by the recorder's process
    assert [(f.parent, f.child) for f in frames] == [("vilma", s.name) for s in scenario.sim.world_sensors]


def test_a_multi_layer_laser_is_recorded_as_one_organized_point_cloud2(tmp_path):
    """On ``laser`` alone (no ``laser/points``), read back bit for bit by vilma, and by Foxglove's decoder as
    a cloud of a row a layer with a ring field."""
    sent = write_layered_recording(tmp_path / "l.mcap")
    back = read_recording(tmp_path / "l.mcap")
    assert back.world_topics == ["laser"] and back.schemas["laser"] == POINT_CLOUD2
    assert "laser/points" not in back.schemas
    assert back.messages("laser") == sent
    with (tmp_path / "l.mcap").open("rb") as f:
        clouds = [msg for _, ch, _, msg in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()
                  if ch.topic == "vilma/vilma/laser"]
    assert [(c.height, c.width, [f.name for f in c.fields]) for c in clouds] == [
        (len(LAYERED.layers), len(LAYERED.bearings), ["x", "y", "z", "range", "ring"])] * len(sent)


def test_a_multi_layer_laser_scan_recorded_before_still_reads_back(tmp_path):
    """A LaserScan of all layers' ranges one after another with the hits on ``laser/points``, as vilma wrote a
    multi-layer laser before its organized clouds."""
    sent = write_old_layered_recording(tmp_path / "old.mcap")
    back = read_recording(tmp_path / "old.mcap")
    assert back.world_topics == ["laser"] and back.schemas["laser"] == LASER_SCAN
    assert back.messages("laser") == sent


def test_a_recording_in_a_with_block_is_finished_even_when_the_block_raises(tmp_path):
    bus = LocalBus()
    with pytest.raises(RuntimeError, match="boom"), BusRecorder(bus, Recorder(tmp_path / "r.mcap")) as rec:
        assert isinstance(rec, BusRecorder)
        bus.publish(topic("sim/status"), SimStatus(stamp_ns=7))
        raise RuntimeError("boom")
    bus.publish(topic("sim/status"), SimStatus(stamp_ns=8))  # after the end: not recorded
    with open(tmp_path / "r.mcap", "rb") as f:
        assert [m.log_time for _, _, m in make_reader(f).iter_messages()] == [7]  # read from its summary: finished
