"""The MCAP file: values read back exactly, ROS 2 and Foxglove types, chunks flushed by age, errors as one line."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_typestore

from tests.record import legacy
from tests.record.ros2 import ros2_decoder
from vilma.bus.topics import SENSOR_TOPICS
from vilma.core import messages as m
from vilma.core.geometry import quaternion_from_euler
from vilma.record import mcap_file
from vilma.record.mcap_file import ChunkPolicy, McapFile, RecordError
from vilma.record.reader import Epochs, RecordingError, read_recording
from vilma.record.recorder import Recorder
from vilma.record.schemas import channels, numeric_layouts
from vilma.scenario.drive_log import COLUMNS
from vilma.sensors import Readings


def _pose_readings(n: int = 200, seed: int = 1) -> Readings:
    rng = np.random.default_rng(seed)
    values = rng.normal(size=(n, 6)) * [100, 100, 1, 0.1, 0.1, 3]
    return Readings("pose", m.Pose, np.arange(1, n + 1, dtype=np.int64) * 20_000_000, values)


def _decoded(path: Path, topic: str) -> list:
    """The messages of ``topic`` as the ``mcap_ros2`` package (Foxglove's ROS 2 decoder) reads them from the
    file's own schemas."""
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        return [msg for _, _, _, msg in reader.iter_decoded_messages(topics=[f"vilma/vilma/{topic}"])]


def test_readings_read_back_exactly_and_decode_as_ros2_messages(tmp_path):
    sent = legacy.readings()  # every sensor, a NaN and an infinity in each
    rec = Recorder(tmp_path / "a.mcap")
    rec.add_readings(sent)
    rec.close()

    back = read_recording(tmp_path / "a.mcap")
    assert back.complete
    for r in sent.values():
        got = back.readings(r.name)
        assert np.array_equal(got.stamp_ns, r.stamp_ns) and got.values.tobytes() == r.values.tobytes(), r.name
    assert {t: back.schemas[t] for t in back.topics} == {
        "pose": "geometry_msgs/msg/PoseStamped", "pose/euler": "geometry_msgs/msg/Vector3Stamped",
        "tf": "foxglove_msgs/msg/FrameTransform", "velocity": "geometry_msgs/msg/TwistStamped",
        "velocity/world": "geometry_msgs/msg/Vector3Stamped", "gps": "sensor_msgs/msg/NavSatFix",
        "gps/enu": "geometry_msgs/msg/PointStamped", "imu": "sensor_msgs/msg/Imu",
        "wheel_speed": "vilma_msgs/msg/WheelSpeeds", "odometry": "nav_msgs/msg/Odometry",
        "odometry/euler": "geometry_msgs/msg/Vector3Stamped", "actuators": "vilma_msgs/msg/ActuatorState"}
    assert set(back.encodings.values()) == {"cdr"}

    pose = sent["pose"]
    ros = _decoded(tmp_path / "a.mcap", "pose")
    assert [p.header.stamp.sec * 10**9 + p.header.stamp.nanosec for p in ros] == pose.stamp_ns.tolist()
    assert {p.header.frame_id for p in ros} == {"map"}
    assert np.array_equal([[p.pose.position.x, p.pose.position.y, p.pose.position.z] for p in ros],
                          pose.values[:, :3], equal_nan=True)
    tf = _decoded(tmp_path / "a.mcap", "tf")
    assert {(t.parent_frame_id, t.child_frame_id) for t in tf} == {("map", "vilma")}
    assert np.array_equal([[t.translation.x, t.translation.y, t.translation.z] for t in tf], pose.values[:, :3],
                          equal_nan=True)
    finite = np.isfinite(pose.values[:, 3:6]).all(axis=1)
    q = np.column_stack(quaternion_from_euler(*pose.values[finite, 3:6].T))
    for got in ([[o.x, o.y, o.z, o.w] for o in (p.pose.orientation for p in ros)],
                [[t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w] for t in tf]):
        assert np.array_equal(np.array(got)[finite], q)
        assert np.isnan(np.array(got)[~finite]).all()  # an infinite angle: no orientation
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)
    fix = _decoded(tmp_path / "a.mcap", "gps")
    assert {(f.header.frame_id, f.status.status, f.status.service, f.position_covariance_type,
             tuple(f.position_covariance)) for f in fix} == {("gps", 0, 1, 0, (0.0,) * 9)}  # a fix, GPS, unknown


def test_the_summary_is_what_the_mcap_library_reads(tmp_path):
    rec = Recorder(tmp_path / "a.mcap")
    rec.add_readings({"pose": _pose_readings(300)})
    rec.add_message("cmd", m.ActuatorCommand(stamp_ns=7, steer=0.25, drive=100.0, autonomous=True))
    rec.add_metadata("scorecard", {"distance_m": 12.5})
    rec.add_attachment("scenario.yaml", "application/yaml", b"task: {speed: 5}\n")
    rec.close()
    with (tmp_path / "a.mcap").open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        by_topic = {c.topic: c.id for c in summary.channels.values()}
        counts = summary.statistics.channel_message_counts
        assert counts[by_topic["vilma/vilma/pose"]] == 300 and counts[by_topic["vilma/vilma/tf"]] == 300
        assert counts[by_topic["vilma/vilma/cmd"]] == 1
        log_times = [msg.log_time for _, _, msg in reader.iter_messages(topics=["vilma/vilma/pose"])]
        assert log_times == (np.arange(1, 301) * 20_000_000).tolist()
        assert {md.name: md.metadata for md in reader.iter_metadata()}["scorecard"] == {"distance_m": "12.5"}
        assert [a.data for a in reader.iter_attachments()] == [b"task: {speed: 5}\n"]
    back = read_recording(tmp_path / "a.mcap")
    assert back.messages("cmd") == [m.ActuatorCommand(stamp_ns=7, steer=0.25, drive=100.0, autonomous=True)]



def test_the_footer_holds_the_summary_crc_the_mcap_specification_defines(tmp_path):
    rec = Recorder(tmp_path / "a.mcap")
    rec.add_readings({"pose": _pose_readings(50)})
    rec.add_metadata("scorecard", {"distance_m": 12.5})
    rec.close()
    data = (tmp_path / "a.mcap").read_bytes()
    # The file ends with the Footer (opcode 0x02, length 20, summary start, summary offset start, summary CRC) and
    # the magic; the CRC is CRC-32 of every byte from the summary's start up to the CRC field (spec, Footer).
    footer = data[-8 - 29:-8]
    opcode, length, summary_start, offsets_start, crc = struct.unpack("<BQQQI", footer)
    assert (opcode, length) == (0x02, 20) and 0 < summary_start < offsets_start
    assert crc == zlib.crc32(data[summary_start:-8 - 4]) != 0

def test_null_floats_come_back_as_nan_or_the_infinite_default(tmp_path):
    rec = Recorder(tmp_path / "a.mcap")
    status = m.DriverStatus(3, "follow", 5.0, 4.5, 2, 10.0, 90.0, float("nan"), False, "")
    rec.add_message("driver/status", status)
    rec.add_message("cmd", m.ActuatorCommand(stamp_ns=4))  # velocity_limit is infinite
    rec.close()
    back = read_recording(tmp_path / "a.mcap")
    got = back.messages("driver/status")[0]
    assert np.isnan(got.cross_track) and got.mode == "follow" and got.index == 2
    assert back.messages("cmd")[0] == m.ActuatorCommand(stamp_ns=4)


def test_a_chunk_is_flushed_once_a_second_old(tmp_path, monkeypatch):
    now = [100.0]
    monkeypatch.setattr(mcap_file.time, "monotonic", lambda: now[0])
    f = McapFile(tmp_path / "a.mcap", ChunkPolicy(chunk_seconds=1.0))
    cid = f.add_channel("vilma/vilma/pose", "vilma.X", b"{}")
    f.write(cid, 1, b"{}")
    now[0] += 0.5
    f.write(cid, 2, b"{}")
    assert read_recording(tmp_path / "a.mcap").count("pose") == 0  # the chunk is still open
    now[0] += 0.5
    f.tick()
    assert read_recording(tmp_path / "a.mcap").count("pose") == 2  # a second old: on disk, file not finished
    f.write(cid, 3, b"{}")
    now[0] += 1.0
    f.write(cid, 4, b"{}")  # a write also closes a chunk that is a second old
    back = read_recording(tmp_path / "a.mcap")
    assert back.count("pose") == 4 and not back.complete
    f.close()
    assert read_recording(tmp_path / "a.mcap").complete


def test_a_torn_last_chunk_is_skipped(tmp_path):
    f = McapFile(tmp_path / "a.mcap", ChunkPolicy(chunk_seconds=1e9))
    cid = f.add_channel("vilma/vilma/pose", "vilma.X", b"{}")
    f.write(cid, 1, b'{"a":1}')
    f.flush()
    whole = (tmp_path / "a.mcap").stat().st_size
    f.write(cid, 2, b'{"a":2}')
    f.flush()
    data = (tmp_path / "a.mcap").read_bytes()
    for cut in (whole + 5, whole + 40, len(data) - 3):
        (tmp_path / "b.mcap").write_bytes(data[:cut])
        back = read_recording(tmp_path / "b.mcap")
        assert back.raw["pose"][0] == [1] or back.raw["pose"][0] == [1, 2]
        assert back.raw["pose"][0][0] == 1 and not back.complete
    f.close()


def test_an_unwritable_path_is_one_line_and_nothing_else(tmp_path):
    errors: list[str] = []
    rec = Recorder(tmp_path / "missing" / "a.mcap", on_error=errors.append)
    rec.add_readings({"pose": _pose_readings()})
    rec.close()
    assert not rec.ok and len(errors) == 1 and "\n" not in errors[0]
    assert str(tmp_path / "missing" / "a.mcap") in errors[0] and "the drive goes on" in errors[0]


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="no /dev/full to fill")
def test_a_full_disk_stops_the_recording_with_one_line():
    errors: list[str] = []
    rec = Recorder(Path("/dev/full"), on_error=errors.append)
    rec.add_readings({"pose": _pose_readings()})
    rec.close()
    assert not rec.ok and len(errors) == 1 and "No space left on device" in errors[0]


def test_a_closed_file_refuses_nothing_and_writes_nothing(tmp_path):
    f = McapFile(tmp_path / "a.mcap")
    f.close()
    size = (tmp_path / "a.mcap").stat().st_size
    f.write(1, 1, b"{}")
    f.close()
    assert (tmp_path / "a.mcap").stat().st_size == size


def test_open_failure_is_a_record_error(tmp_path):
    with pytest.raises(RecordError, match="cannot record to"):
        McapFile(tmp_path / "no" / "a.mcap")


def _vector(v) -> list[float]:
    return [v.x, v.y, v.z]


STANDARD = {
    "pose": (lambda g: _vector(g.pose.position), ("x", "y", "z")),
    "pose/euler": (lambda g: _vector(g.vector), ("roll", "pitch", "yaw")),
    "velocity": (lambda g: [*_vector(g.twist.linear), *_vector(g.twist.angular)], ("vx", "vy", "vz", "wx", "wy", "wz")),
    "velocity/world": (lambda g: _vector(g.vector), ("vx_world", "vy_world", "vz_world")),
    "gps": (lambda g: [g.latitude, g.longitude, g.altitude], ("latitude", "longitude", "altitude")),
    "gps/enu": (lambda g: _vector(g.point), ("x", "y", "z")),
    "imu": (lambda g: [*_vector(g.orientation), g.orientation.w, *_vector(g.angular_velocity),
                       *_vector(g.linear_acceleration)], ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az")),
    "odometry": (lambda g: [g.pose.pose.position.x, g.pose.pose.position.y, g.twist.twist.linear.x,
                            g.twist.twist.angular.z], ("x", "y", "speed", "yaw_rate")),
    "odometry/euler": (lambda g: _vector(g.vector), ("roll", "pitch", "yaw")),
}
"""Standard topic -> where its type's definition puts vilma's fields, and which fields (odometry's roll and pitch
are 0)."""
FRAMES = {"pose": ("map", None), "pose/euler": ("map", None), "velocity": ("vilma", None),
          "velocity/world": ("map", None), "gps": ("gps", None), "gps/enu": ("map", None), "imu": ("vilma", None),
          "odometry": ("odom", "vilma"), "odometry/euler": ("odom", None)}
"""Standard topic -> (header frame, child frame)."""
_STORE = get_typestore(Stores.ROS2_HUMBLE)


def test_every_numeric_layout_is_the_ros2_message_its_schema_says():
    """Each layout's payloads, decoded by ``mcap_ros2`` from the layout's own ``ros2msg`` text, hold the stamp and
    the source's values where the standard type's definition puts them, stamps across second boundaries
    included; a standard type's payloads are those ``rosbags`` writes from ROS 2 Humble's own definitions."""
    rng = np.random.default_rng(3)
    stamps = np.array([0, 999_999_999, 1_000_000_000, 3_600_000_000_017], np.int64)
    for name, layout in numeric_layouts("vilma").items():
        source = name.split("/")[0] if name != "tf" else "pose"
        fields = COLUMNS if name == "drive_log" else SENSOR_TOPICS[source].__struct_fields__[1:]
        values = rng.normal(size=(4, len(fields)))
        decode = ros2_decoder(layout.schema_name, layout.schema)
        payloads = layout.encode(stamps, values)
        got = [decode(p) for p in payloads]
        stamp = [g.header.stamp if hasattr(g, "header") else getattr(g, "stamp", None) or g.timestamp for g in got]
        assert [t.sec * 10**9 + t.nanosec for t in stamp] == stamps.tolist(), name
        column = {"roll": 0.0, "pitch": 0.0} | {f: values[:, j] for j, f in enumerate(fields)}
        if layout.schema_name.startswith("vilma_msgs/"):
            assert [[getattr(g, f) for f in fields] for g in got] == values.tolist(), name
        elif name == "tf":
            assert [[g.translation.x, g.translation.y, g.translation.z] for g in got] == values[:, :3].tolist()
        else:
            where, carried = STANDARD[name]
            want = np.column_stack(np.broadcast_arrays(*(column[f] for f in carried)))
            assert np.array_equal([where(g) for g in got], want), name
            if name in ("pose", "odometry"):
                q = [getattr(g.pose, "pose", g.pose).orientation for g in got]
                want = np.column_stack(quaternion_from_euler(column["roll"], column["pitch"], column["yaw"]))
                assert np.array_equal([[o.x, o.y, o.z, o.w] for o in q], want), name
            frame, child = FRAMES[name]
            assert {(g.header.frame_id, getattr(g, "child_frame_id", None)) for g in got} == {(frame, child)}, name
            assert all(_STORE.serialize_cdr(_STORE.deserialize_cdr(p, layout.schema_name), layout.schema_name) == p
                       for p in payloads), name
        assert layout.encode_one(int(stamps[1]), values[1].tolist()) == payloads[1]


def test_a_vilma_0_1_json_recording_still_reads(tmp_path):
    """Numeric topics were JSON objects with ``stamp_ns`` and the fields before CDR; null is NaN."""
    f = McapFile(tmp_path / "old.mcap")
    cid = f.add_channel("vilma/vilma/wheel_speed", "vilma.WheelSpeeds", b"{}")
    f.write(cid, 20, b'{"timestamp":{"sec":0,"nsec":20},"stamp_ns":20,"fl":1.5,"fr":null,"rl":-2,"rr":1e300}')
    f.close()
    got = read_recording(tmp_path / "old.mcap").readings("wheel_speed")
    assert got.stamp_ns.tolist() == [20] and np.array_equal(got.values, [[1.5, np.nan, -2.0, 1e300]],
                                                           equal_nan=True)


def test_a_numeric_topic_of_another_size_is_one_clear_error(tmp_path):
    layout = numeric_layouts("vilma")["wheel_speed"]
    f = McapFile(tmp_path / "bad.mcap")
    cid = f.add_channel("vilma/vilma/wheel_speed", layout.schema_name, layout.schema, encoding="cdr")
    f.write(cid, 20, layout.encode_one(20, [1.0, 2.0, 3.0, 4.0])[:-8])
    f.close()
    with pytest.raises(RecordingError, match=r"bad.mcap: topic wheel_speed: a vilma_msgs/msg/WheelSpeeds message "
                                             r"of 36 bytes, not 44"):
        read_recording(tmp_path / "bad.mcap").readings("wheel_speed")


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from([*SENSOR_TOPICS, "drive_log"]),
       stamps=st.lists(st.integers(0, 2**31 * 10**9 - 1), min_size=1, max_size=5),  # builtin_interfaces/Time's range
       data=st.data())
def test_numeric_payloads_decode_to_what_was_encoded_bit_for_bit(name, stamps, data):
    """A topic's values, from its own messages and those written beside it."""
    fields = COLUMNS if name == "drive_log" else SENSOR_TOPICS[name].__struct_fields__[1:]
    values = np.array([data.draw(st.lists(st.floats(), min_size=len(fields), max_size=len(fields)))
                       for _ in stamps], np.float64)
    column = {}
    for c in channels(name):
        layout = numeric_layouts("vilma")[c]
        payloads = layout.encode(np.array(stamps, np.int64), values)
        got_stamps, got = layout.decode(payloads)
        assert got_stamps.tolist() == stamps
        column |= {f: got[:, j] for j, f in enumerate(layout.fields) if f is not None}
        cut = data.draw(st.integers(0, len(payloads[0]) - 1))
        with pytest.raises(ValueError, match=f"a {layout.schema_name} message of {cut} bytes"):
            layout.decode([*payloads[:-1], payloads[-1][:cut]])
    assert np.column_stack([column[f] for f in fields]).tobytes() == values.tobytes()


def test_a_recording_made_before_the_standard_types_reads_back_exactly():
    """``data/vilma_msgs.mcap``: every sensor as ``vilma_msgs/msg/<Type>``, written by vilma before this change."""
    back = read_recording(legacy.FILE)
    assert back.schemas["pose"] == "vilma_msgs/msg/Pose" and back.schemas["gps/fix"] == "foxglove_msgs/msg/LocationFix"
    for r in legacy.readings().values():
        got = back.readings(r.name)
        assert np.array_equal(got.stamp_ns, r.stamp_ns) and got.values.tobytes() == r.values.tobytes(), r.name
    assert back.drive_log().tobytes() == legacy.log_rows().tobytes()
    assert back.messages("cmd") == [legacy.CMD]


def test_a_standard_topic_without_the_topic_beside_it_is_one_clear_error(tmp_path):
    layout = numeric_layouts("vilma")["pose"]
    f = McapFile(tmp_path / "bad.mcap")
    cid = f.add_channel("vilma/vilma/pose", layout.schema_name, layout.schema, encoding="cdr")
    f.write(cid, 20, layout.encode_one(20, [1.0, 2.0, 3.0, 0.0, 0.0, 0.5]))
    f.close()
    with pytest.raises(RecordingError, match=r"bad.mcap: topic pose needs topic pose/euler "
                                             r"\(geometry_msgs/msg/Vector3Stamped\) beside it, which the file lacks"):
        read_recording(tmp_path / "bad.mcap").readings("pose")


FRAME_NS = 20_000_000
"""A frame of the simulator in the tests of epochs (50 Hz)."""


@settings(max_examples=300, deadline=None)
@given(epochs=st.lists(st.tuples(st.integers(2, 30), st.integers(1, 31), st.integers(1, 31)), min_size=1,
                       max_size=6),
       late=st.booleans())
def test_every_message_gets_the_epoch_of_the_sim_clock_it_was_stamped_in(epochs, late):
    """Each epoch of the sim's clock: frames 1..n (a reset sets the clock back to 0), each a pose then a
    sim/status; the driver's status in frames a..b-1 only (it falls silent and speaks again), and, if ``late``,
    the status of an epoch's last frame written after the next epoch's first frame (from another process)."""
    written, held = [], []  # (topic, stamp, its epoch), in file order; a status held back
    for k, (n, a, b) in enumerate(epochs):
        for j in range(1, n + 1):
            written += [("pose", j * FRAME_NS, k), ("sim/status", j * FRAME_NS, k), *held]
            held = []
            if a <= j < b:
                (held if late and j == n else written).append(("driver/status", j * FRAME_NS, k))
    written += held
    told = Epochs()
    assert [told.of(name, t) for name, t, _ in written] == [k for _, _, k in written]


def test_a_topic_comes_back_in_epoch_then_stamp_order(tmp_path):
    rec = Recorder(tmp_path / "a.mcap")
    for k in (1, 2, 3, 1, 2):  # a reset after the third frame: the clock starts again
        rec.add_message("pose", m.Pose(k * FRAME_NS, float(k), 0.0, 0.0, 0.0, 0.0, 0.0))
        rec.add_message("driver/status", m.DriverStatus(k * FRAME_NS, "manual", 0.0, 0.0, 0, 0.0, 0.0, 0.0, False, ""))
    rec.close()
    back = read_recording(tmp_path / "a.mcap")
    stamps = [k * FRAME_NS for k in (1, 2, 3, 1, 2)]
    assert back.readings("pose").stamp_ns.tolist() == stamps
    assert [s.stamp_ns for s in back.messages("driver/status")] == stamps
    assert back.epoch("pose").tolist() == back.epoch("driver/status").tolist() == [0, 0, 0, 1, 1]
