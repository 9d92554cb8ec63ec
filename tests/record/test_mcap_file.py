"""The MCAP file: values read back exactly, Foxglove schemas, chunks flushed by age, errors as one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from vilma.core import messages as m
from vilma.core.geometry import quaternion_from_euler
from vilma.record import mcap_file
from vilma.record.mcap_file import ChunkPolicy, McapFile, RecordError
from vilma.record.reader import read_recording
from vilma.record.recorder import Recorder
from vilma.sensors import Readings


def _pose_readings(n: int = 200, seed: int = 1) -> Readings:
    rng = np.random.default_rng(seed)
    values = rng.normal(size=(n, 6)) * [100, 100, 1, 0.1, 0.1, 3]
    return Readings("pose", m.Pose, np.arange(1, n + 1, dtype=np.int64) * 20_000_000, values)


def test_readings_read_back_exactly_with_foxglove_fields(tmp_path):
    pose = _pose_readings()
    gps = Readings("gps", m.GpsFix, pose.stamp_ns[::5], np.column_stack([
        -22.8 + pose.values[::5, :1] * 1e-6, -47.0 + pose.values[::5, 1:2] * 1e-6, 600 + pose.values[::5, 2:3],
        pose.values[::5, :3]]))
    rec = Recorder(tmp_path / "a.mcap")
    rec.add_readings({"pose": pose, "gps": gps})
    rec.close()

    back = read_recording(tmp_path / "a.mcap")
    assert back.complete
    for r in (pose, gps):
        got = back.readings(r.name)
        assert np.array_equal(got.stamp_ns, r.stamp_ns) and np.array_equal(got.values, r.values)
    assert back.schemas["pose"] == "foxglove.PoseInFrame"
    assert back.schemas["gps"] == "foxglove.LocationFix"
    assert back.schemas["tf"] == "foxglove.FrameTransform"
    q = np.column_stack(quaternion_from_euler(*pose.values[:, 3:6].T))
    fox = back.objects("pose")
    assert [o["pose"]["position"]["x"] for o in fox] == pose.values[:, 0].tolist()
    assert np.array_equal([[o["pose"]["orientation"][k] for k in "xyzw"] for o in fox], q)
    assert [o["timestamp"]["sec"] * 10**9 + o["timestamp"]["nsec"] for o in fox] == pose.stamp_ns.tolist()
    tf = back.objects("tf")
    assert {(o["parent_frame_id"], o["child_frame_id"]) for o in tf} == {("map", "vilma")}
    assert [o["translation"]["y"] for o in tf] == pose.values[:, 1].tolist()
    assert [o["latitude"] for o in back.objects("gps")] == gps.values[:, 0].tolist()


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


def test_one_message_encodes_as_the_bulk_path_does():
    import json

    from vilma.record.schemas import numeric_layouts

    rng = np.random.default_rng(3)
    for name, layout in numeric_layouts("vilma").items():
        width = len(layout.fields) or 6  # tf: the pose's fields
        values = rng.normal(size=(4, width))
        stamps = np.array([0, 999_999_999, 1_000_000_000, 3_600_000_000_017], np.int64)
        bulk = [json.loads(b) for b in layout.encode(stamps, values)]
        one = [json.loads(layout.encode_one(int(t), v.tolist())) for t, v in zip(stamps, values, strict=True)]
        assert _close(bulk, one), name


def _close(a, b) -> bool:
    """Equal, numbers within 1e-15 (numpy's and math's cosines may differ in the last bit)."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float):
        return abs(a - b) <= 1e-15
    return a == b
