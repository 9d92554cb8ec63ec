"""The recorder in its own process: the same file as in-process, finished even when the parent vanishes, and
an error reported, not raised."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from vilma.core.messages import Pose
from vilma.record.process import RecorderProcess
from vilma.record.reader import RecordingError, read_recording
from vilma.record.recorder import Recorder
from vilma.sensors import Readings

STAMPS = np.arange(1, 201, dtype=np.int64) * 20_000_000
VALUES = np.column_stack([np.linspace(0, 10, 200), np.linspace(0, -5, 200), np.zeros((200, 3)),
                          np.linspace(-1, 1, 200)])


def _poses(rec) -> None:
    for k in range(4):  # four blocks of 50 poses
        part = slice(50 * k, 50 * (k + 1))
        rec.add_readings({"pose": Readings("pose", Pose, STAMPS[part], VALUES[part])})


def test_a_child_writes_the_file_the_recorder_writes(tmp_path):
    child, here = RecorderProcess(tmp_path / "child.mcap"), Recorder(tmp_path / "here.mcap")
    for rec in (child, here):
        _poses(rec)
        rec.add_metadata("run", {"completed": True})
        rec.close()
    assert child.error is None and not child.ok
    a, b = read_recording(tmp_path / "child.mcap"), read_recording(tmp_path / "here.mcap")
    assert a.topics == b.topics and a.meta("run") == b.meta("run") == {"completed": True}
    assert np.array_equal(a.readings("pose").values, VALUES) and np.array_equal(a.readings("pose").stamp_ns, STAMPS)


def test_the_file_is_finished_when_the_parent_is_killed(tmp_path):
    script = (f"import os, signal; from pathlib import Path; from tests.record.test_process import _poses; "
              f"from vilma.record.process import RecorderProcess; rec = RecorderProcess(Path({str(tmp_path)!r}) / "
              f"'orphan.mcap'); _poses(rec); rec.add_metadata('run', {{'completed': False}}); "
              f"import time; time.sleep(0.5); os.kill(os.getpid(), signal.SIGKILL)")
    parent = subprocess.run([sys.executable, "-c", script], cwd=Path(__file__).resolve().parents[2], timeout=60)
    assert parent.returncode == -signal.SIGKILL
    deadline = time.monotonic() + 30
    while True:  # the child finishes the file once it sees the end of the pipe (it may still be compiling)
        try:
            back = read_recording(tmp_path / "orphan.mcap")
            if back.complete:
                break
        except RecordingError:
            pass
        assert time.monotonic() < deadline, "the orphaned recording was never finished"
        time.sleep(0.1)
    assert len(back.readings("pose")) == 200 and back.meta("run") == {"completed": False}


def test_a_failing_call_ends_the_recording_and_keeps_what_was_written(tmp_path):
    rec = RecorderProcess(tmp_path / "bug.mcap", on_error=lambda line: None)
    _poses(rec)
    rec.add_metadata("run")  # a call the recorder cannot take
    rec.close()
    assert rec.error.startswith("add_metadata: ") and "argument" in rec.error
    assert len(read_recording(tmp_path / "bug.mcap").readings("pose")) == 200


def test_an_error_is_reported_by_close_and_ok(tmp_path):
    rec = RecorderProcess(tmp_path / "no" / "such" / "dir" / "x.mcap")
    _poses(rec)
    rec.close()
    assert not rec.ok and "x.mcap" in rec.error
