"""The recorder in a process of its own: the same file as in the caller's process, finished even when the
caller vanishes, chunks on disk while it is quiet, and an error reported, not raised."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from vilma.app.batch import BUNDLED
from vilma.bus.topics import SENSOR_TOPICS
from vilma.core.messages import Pose
from vilma.record import run as run_module
from vilma.record import run_recorder
from vilma.record.process import Joined, RecorderProcess
from vilma.record.reader import RecordingError, read_recording
from vilma.record.recorder import Recorder
from vilma.record.run_recorder import RunRecorder, _write
from vilma.scenario import load_scenario
from vilma.scenario.drive_log import COLUMNS, DriveLog
from vilma.sensors import Readings
from vilma.sim import Simulator

STAMPS = np.arange(1, 201, dtype=np.int64) * 20_000_000
VALUES = np.column_stack([np.linspace(0, 10, 200), np.linspace(0, -5, 200), np.zeros((200, 3)),
                          np.linspace(-1, 1, 200)])
ROOT = Path(__file__).resolve().parents[2]


def _poses(call) -> None:
    for k in range(4):  # four blocks of 50 poses
        part = slice(50 * k, 50 * (k + 1))
        call(Recorder.add_readings, {"pose": Readings("pose", Pose, STAMPS[part], VALUES[part])})


def test_the_child_writes_the_file_the_recorder_writes(tmp_path):
    child, here = RecorderProcess(tmp_path / "child.mcap"), Recorder(tmp_path / "here.mcap")
    for call, close in ((child.call, child.close), (lambda fn, *a: fn(here, *a), here.close)):
        _poses(call)
        call(Recorder.add_metadata, "run", {"completed": True})
        close()
    assert child.error is None and not child.ok
    a, b = read_recording(tmp_path / "child.mcap"), read_recording(tmp_path / "here.mcap")
    assert a.complete and a.topics == b.topics and a.meta("run") == b.meta("run") == {"completed": True}
    assert np.array_equal(a.readings("pose").values, VALUES) and np.array_equal(a.readings("pose").stamp_ns, STAMPS)


def test_the_file_is_finished_when_the_parent_is_killed(tmp_path):
    script = ("import os, signal; from pathlib import Path; from tests.record.test_process import _poses; "
              "from vilma.record.process import Joined, RecorderProcess; from vilma.record.recorder import Recorder; "
              f"rec = RecorderProcess(Path({str(tmp_path)!r}) / 'orphan.mcap'); _poses(rec.call); "
              "rec.call(Recorder.add_metadata, 'run', {'completed': False}); os.kill(os.getpid(), signal.SIGKILL)")
    parent = subprocess.run([sys.executable, "-c", script], cwd=ROOT, timeout=60)
    assert parent.returncode == -signal.SIGKILL
    deadline = time.monotonic() + 30
    while True:  # the child finishes the file once it sees the end of the pipe (it may still be starting)
        try:
            back = read_recording(tmp_path / "orphan.mcap")
            if back.complete:
                break
        except RecordingError:
            pass
        assert time.monotonic() < deadline, "the orphaned recording was never finished"
        time.sleep(0.1)
    assert np.array_equal(back.readings("pose").values, VALUES) and back.meta("run") == {"completed": False}


def test_a_quiet_recording_has_its_chunk_on_disk_within_a_second(tmp_path):
    rec = RecorderProcess(tmp_path / "quiet.mcap")
    _poses(rec.call)
    deadline = time.monotonic() + 30
    while _count(tmp_path / "quiet.mcap", "pose") < 200:  # no call comes: the child ticks
        assert time.monotonic() < deadline
        time.sleep(0.1)
    assert not read_recording(tmp_path / "quiet.mcap").complete
    rec.close()


def _count(path: Path, topic: str) -> int:
    try:
        return read_recording(path).count(topic)
    except RecordingError:  # not there yet: the child is starting
        return 0


def test_calls_larger_than_the_ring_and_more_than_it_holds_arrive_whole(tmp_path):
    ring = 1 << 20
    rec = RecorderProcess(tmp_path / "big.mcap", ring=ring)
    rec.call(Recorder.add_attachment, "big.bin", "application/octet-stream", bytes(range(256)) * (ring // 256))
    n = ring // (3 * 7 * 8)  # a third of the ring a call: it wraps around, and waits for room
    stamps = np.arange(1, n + 1, dtype=np.int64) * 20_000_000
    values = np.random.default_rng(0).normal(size=(n, 6))
    for k in range(7):
        rec.call(Recorder.add_readings, {"pose": Readings("pose", Pose, stamps + k * n * 20_000_000, values)})
    rec.close()
    back = read_recording(tmp_path / "big.mcap")
    assert rec.error is None and back.attachments["big.bin"] == bytes(range(256)) * (ring // 256)
    got = back.readings("pose")
    assert np.array_equal(got.values, np.tile(values, (7, 1))) and np.all(np.diff(got.stamp_ns) == 20_000_000)


@pytest.mark.parametrize("ring", [1 << 20, 1 << 12])  # through the ring; too big for it: through the pipe
def test_joined_and_plain_arrays_arrive_as_they_were(tmp_path, ring):
    rec = RecorderProcess(tmp_path / "j.mcap", ring=ring)
    rows = np.asfortranarray(np.arange(3.0 * len(COLUMNS)).reshape(3, len(COLUMNS)))  # not C-ordered: pickled
    rows[:, 0] = [0.02, 0.04, 0.06]
    rec.call(_write, {"pose": (Pose, Joined([STAMPS[:120], STAMPS[120:121], STAMPS[121:]]),
                               Joined([VALUES[:120], VALUES[120:121], VALUES[121:]]))}, rows)
    rec.close()
    back = read_recording(tmp_path / "j.mcap")
    assert rec.error is None and np.array_equal(back.drive_log(), rows)
    assert np.array_equal(back.readings("pose").values, VALUES) and np.array_equal(back.readings("pose").stamp_ns,
                                                                                   STAMPS)


@pytest.mark.slow
def test_a_run_hands_its_blocks_over_in_parts_the_ring_holds(tmp_path, monkeypatch):
    """While the process starts, and whenever it is behind, a run keeps what the ring has no room for and hands
    it over later, in parts: every reading and log row arrives, in order."""
    monkeypatch.setattr(run_recorder, "RecorderProcess", functools.partial(RecorderProcess, ring=1 << 20))
    monkeypatch.setattr(RunRecorder, "BLOCK", 100)  # a hand-over tried every other block
    log = DriveLog(capacity=16)
    rec = RunRecorder(tmp_path / "run.mcap", load_scenario(BUNDLED / "paper_fig11_speed_10.yaml"))
    with Simulator() as sim:  # any simulator: the scenario has no road, whose traffic the recorder would read
        rec.started(sim, log)  # the recorder reads the log alone
    rng = np.random.default_rng(2)
    n, periods = 3000, 50  # a block: 168 kB of poses; the ring takes two or three at a time
    values = rng.normal(size=(30 * n, 6))
    rows = rng.normal(size=(30 * periods, len(COLUMNS)))
    rows[:, 0] = np.arange(len(rows)) * 0.02  # sim time [s]
    stamps = np.arange(1, 30 * n + 1, dtype=np.int64) * 1_000_000
    for k in range(30):
        log.extend(rows[k * periods:(k + 1) * periods])
        part = slice(k * n, (k + 1) * n)
        rec.add({"pose": Readings("pose", Pose, stamps[part], values[part])})
    rec.failed(interrupted=False)
    back = read_recording(tmp_path / "run.mcap")
    assert rec.recorder.error is None and back.complete
    assert np.array_equal(back.readings("pose").values, values) and np.array_equal(back.readings("pose").stamp_ns,
                                                                                   stamps)
    assert np.array_equal(back.drive_log(), rows)


def test_a_killed_child_stops_the_recording_and_nothing_else(tmp_path):
    rec = RecorderProcess(tmp_path / "gone.mcap")
    _poses(rec.call)
    os.kill(rec._child.pid, signal.SIGKILL)
    deadline = time.monotonic() + 30
    while rec.ok:
        assert time.monotonic() < deadline, "the recorder never noticed its process was gone"
        time.sleep(0.05)
    _poses(rec.call)  # dropped, no error raised
    rec.close()
    assert "ended early" in rec.error


def test_a_failing_call_ends_the_recording_and_keeps_what_was_written(tmp_path):
    rec = RecorderProcess(tmp_path / "bug.mcap")
    _poses(rec.call)
    rec.call(Recorder.add_metadata, "run")  # a call the recorder cannot take
    rec.call(Recorder.add_metadata, "late", {"a": 1})  # after the failure: dropped
    rec.close()
    assert rec.error.startswith("add_metadata: ") and "argument" in rec.error and not rec.ok
    back = read_recording(tmp_path / "bug.mcap")
    assert len(back.readings("pose")) == 200 and "late" not in back.metadata


def test_an_unwritable_path_is_reported_by_close_and_ok(tmp_path):
    rec = RecorderProcess(tmp_path / "no" / "such" / "dir" / "x.mcap")
    _poses(rec.call)
    rec.close()
    assert not rec.ok and "x.mcap" in rec.error


@pytest.mark.slow
def test_a_killed_paced_run_keeps_its_run_mcap(tmp_path, processes):
    """``vilma run --realtime``: readings reach the recorder at least every half second of wall time; killed,
    the run leaves its file finished by the recorder's process."""
    p = processes.vilma("run", "course_30kmh_stanley", "--realtime", "1", "--out", str(tmp_path), cwd=ROOT,
                        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 180  # a busy machine, and a cold compiled-code cache (a minute)
    pose = None
    while pose is None or not len(pose) or pose.stamp_ns[-1] < 3_000_000_000:
        assert time.monotonic() < deadline and p.poll() is None, p.stderr.read() if p.poll() is not None else ""
        time.sleep(0.2)
        try:
            pose = read_recording(tmp_path / "run.mcap").readings("pose")
        except RecordingError:  # not there yet
            continue
    p.kill()
    p.communicate(timeout=60)
    deadline = time.monotonic() + 60
    while not (back := read_recording(tmp_path / "run.mcap")).complete:
        assert time.monotonic() < deadline, "the killed run's recording was never finished"
        time.sleep(0.1)
    pose = back.readings("pose")
    assert np.all(np.diff(pose.stamp_ns) == 20_000_000) and pose.stamp_ns[-1] >= 3_000_000_000
    assert back.count("tf") == len(pose) and len(back.drive_log()) >= 100


@pytest.mark.slow
def test_a_run_recorded_here_holds_what_its_recording_process_writes(tmp_path):
    """:class:`RecorderHere` (a short unpaced run's) and the recording process write the same messages."""
    from vilma.scenario.runner import run

    scenario = load_scenario(BUNDLED / "paper_fig11_speed_10.yaml")
    back = []
    for here in (False, True):
        path = tmp_path / f"here_{here}.mcap"
        recorder = RunRecorder(path, scenario, here)
        result = run(scenario, observers=[recorder])
        recorder.close()
        assert recorder.recorder.error is None
        back.append(read_recording(path))
    beside, here = back
    timed = COLUMNS.index("controller_us")  # the controller's wall time a step: this machine's, not the drive's
    same = np.delete(beside.drive_log(), timed, axis=1), np.delete(here.drive_log(), timed, axis=1)
    assert np.array_equal(*same, equal_nan=True) and len(same[1]) == len(result.log)
    assert sorted(beside.topics) == sorted(here.topics)  # channels in the order their first message came
    sensors = [t for t in here.topics if t in SENSOR_TOPICS]
    assert len(sensors) >= 5  # pose, velocity, GPS, IMU, wheel speeds...
    for name in sensors:
        a, b = beside.readings(name), here.readings(name)
        assert np.array_equal(a.stamp_ns, b.stamp_ns) and np.array_equal(a.values, b.values)


@pytest.mark.parametrize("duration, where", [(run_module.HERE_MAX_S, "RecorderHere"),
                                             (run_module.HERE_MAX_S + 1, "RecorderProcess")])
def test_an_unpaced_run_records_here_up_to_its_limit_and_beside_beyond(tmp_path, monkeypatch, duration, where):
    chosen = []
    for name in ("RecorderHere", "RecorderProcess"):
        real = getattr(run_recorder, name)
        monkeypatch.setattr(run_recorder, name, lambda *a, _real=real, _name=name, **k: chosen.append(_name) or
                            _real(*a, **k))
    scenario = load_scenario(BUNDLED / "paper_fig11_speed_10.yaml", {"duration": str(duration)})
    run_module.record_run(scenario, tmp_path / "out", plots=False)
    assert chosen == [where] and read_recording(tmp_path / "out" / "run.mcap").complete
