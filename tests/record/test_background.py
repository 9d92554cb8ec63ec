"""The recorder in a thread of its own: the same file as in the caller's thread, chunks on disk while the caller
is quiet or killed, and an error reported, not raised."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from vilma.core.messages import Pose
from vilma.record.background import BackgroundRecorder
from vilma.record.reader import RecordingError, read_recording
from vilma.record.recorder import Recorder
from vilma.sensors import Readings

STAMPS = np.arange(1, 201, dtype=np.int64) * 20_000_000
VALUES = np.column_stack([np.linspace(0, 10, 200), np.linspace(0, -5, 200), np.zeros((200, 3)),
                          np.linspace(-1, 1, 200)])
ROOT = Path(__file__).resolve().parents[2]


def _poses(call) -> None:
    for k in range(4):  # four blocks of 50 poses
        part = slice(50 * k, 50 * (k + 1))
        call(Recorder.add_readings, {"pose": Readings("pose", Pose, STAMPS[part], VALUES[part])})


def test_the_thread_writes_the_file_the_recorder_writes(tmp_path):
    background, here = BackgroundRecorder(tmp_path / "thread.mcap"), Recorder(tmp_path / "here.mcap")
    for call, close in ((background.call, background.close), (lambda fn, *a: fn(here, *a), here.close)):
        _poses(call)
        call(Recorder.add_metadata, "run", {"completed": True})
        close()
    assert background.error is None and not background.ok
    a, b = read_recording(tmp_path / "thread.mcap"), read_recording(tmp_path / "here.mcap")
    assert a.complete and a.topics == b.topics and a.meta("run") == b.meta("run") == {"completed": True}
    assert np.array_equal(a.readings("pose").values, VALUES) and np.array_equal(a.readings("pose").stamp_ns, STAMPS)


def test_a_killed_process_leaves_what_was_handed_over_a_second_before(tmp_path):
    script = ("import os, signal, time; from pathlib import Path; "
              "from tests.record.test_background import _poses; "
              "from vilma.record.background import BackgroundRecorder; "
              f"rec = BackgroundRecorder(Path({str(tmp_path)!r}) / 'killed.mcap'); _poses(rec.call); "
              "time.sleep(2.0); os.kill(os.getpid(), signal.SIGKILL)")
    p = subprocess.run([sys.executable, "-c", script], cwd=ROOT, timeout=60)
    assert p.returncode == -signal.SIGKILL
    back = read_recording(tmp_path / "killed.mcap")  # the thread closed the chunk once it was a second old
    assert not back.complete and np.array_equal(back.readings("pose").values, VALUES)


def test_a_failing_call_ends_the_recording_and_keeps_what_was_written(tmp_path):
    lines: list[str] = []
    rec = BackgroundRecorder(tmp_path / "bug.mcap", on_error=lines.append)
    _poses(rec.call)
    rec.call(Recorder.add_metadata, "run")  # a call the recorder cannot take
    rec.call(Recorder.add_metadata, "late", {"a": 1})  # after the failure: dropped
    rec.close()
    assert rec.error.startswith("add_metadata: ") and "argument" in rec.error and not rec.ok
    assert len(lines) == 1 and lines[0].startswith("recording stopped by add_metadata")
    back = read_recording(tmp_path / "bug.mcap")
    assert len(back.readings("pose")) == 200 and "late" not in back.metadata


def test_an_unwritable_path_is_reported_by_close_and_ok(tmp_path):
    rec = BackgroundRecorder(tmp_path / "no" / "such" / "dir" / "x.mcap", on_error=lambda line: None)
    _poses(rec.call)
    rec.close()
    assert not rec.ok and "x.mcap" in rec.error


def test_a_killed_paced_run_keeps_its_run_mcap_up_to_a_second_before(tmp_path):
    """``vilma run --realtime``: readings reach the recorder at least every half second of wall time."""
    p = subprocess.Popen([sys.executable, "-m", "vilma.cli", "run", "course_30kmh_stanley", "--realtime", "1",
                          "--out", str(tmp_path)], cwd=ROOT, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    pose = None
    while pose is None or not len(pose) or pose.stamp_ns[-1] < 3_000_000_000:
        assert time.monotonic() < deadline and p.poll() is None, p.stderr.read() if p.poll() is not None else ""
        time.sleep(0.2)
        try:
            pose = read_recording(tmp_path / "run.mcap").readings("pose")
        except RecordingError:  # not there yet
            continue
    p.kill()
    p.communicate(timeout=20)
    back = read_recording(tmp_path / "run.mcap")
    assert not back.complete
    pose = back.readings("pose")
    assert np.all(np.diff(pose.stamp_ns) == 20_000_000) and pose.stamp_ns[-1] >= 3_000_000_000
    assert back.count("tf") == len(pose) and len(back.drive_log()) >= 100
