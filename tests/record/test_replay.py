"""Replay: a recording back onto the bus in stamp order, paced, with pause, seek and speed."""

from __future__ import annotations

import numpy as np
import pytest

from tests.record import legacy
from tests.record.world_messages import (
    PERIOD_NS,
    WORLD_TOPICS,
    write_layered_recording,
    write_old_layered_recording,
    write_world_recording,
)
from vilma.app import programs
from vilma.app.batch import BUNDLED
from vilma.bus.base import BoundedQueue
from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.record.reader import read_recording
from vilma.record.replay import Replayer
from vilma.record.schemas import COMPANIONS
from vilma.scenario import load_scenario


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("rec") / "up.mcap"
    programs.up(load_scenario(BUNDLED / "course_30kmh_stanley.yaml"), 50.0, 2.0, lambda _: None, record=path)
    return read_recording(path)


NOT_PLAYED = (*(c for cs in COMPANIONS.values() for c in cs), "drive_log", "driver/cmd")
"""Topics a replay does not publish: written beside others, not a bus topic, or the orders the driver took."""


def test_replay_publishes_every_message_as_recorded(recording):
    bus = LocalBus()
    poses = BoundedQueue(bus, topic("pose"), maxsize=100_000)
    cmds = BoundedQueue(bus, topic("cmd"), maxsize=100_000)
    player = Replayer(recording, bus, speed=50.0).start()
    assert player.wait(timeout=30)
    player.close()
    assert poses.drain() == recording.messages("pose")
    assert cmds.drain() == recording.messages("cmd")
    assert player.published == sum(recording.count(n) for n in recording.topics if n not in NOT_PLAYED)


def test_pause_stops_publishing_and_seek_jumps(recording):
    bus = LocalBus()
    poses = BoundedQueue(bus, topic("pose"), maxsize=100_000)
    player = Replayer(recording, bus, speed=1.0).start()
    first = poses.wait(lambda _: True, timeout=10)
    assert first is not None
    player.pause()
    poses.drain()
    assert not player.wait(timeout=0.3)  # paused: not finished, and nothing came meanwhile
    assert poses.drain() == []
    player.seek(1.5)
    player.set_speed(20.0)
    player.resume()
    nxt = poses.wait(lambda _: True, timeout=10)
    assert nxt.stamp_ns == min(p.stamp_ns for p in recording.messages("pose") if p.stamp_ns >= 1_500_000_000)
    assert player.wait(timeout=30)
    player.close()


def test_a_seek_outside_the_recording_is_refused(recording):
    player = Replayer(recording, LocalBus())
    end = player.end_ns * 1e-9
    for t in (-1.0, end + 1e-3, 1e9, float("nan")):
        with pytest.raises(ValueError, match=rf"is not within the recording's sim time, 0 to {end:.2f} s"):
            player.seek(t)
    player.seek(end)  # the last message plays next
    assert player.position_ns == player.end_ns
    player.close()


def test_a_recording_made_before_the_standard_types_replays_as_written():
    bus = LocalBus()
    sensors = {name: BoundedQueue(bus, topic(name), maxsize=1000) for name in legacy.readings()}
    cmds = BoundedQueue(bus, topic("cmd"), maxsize=10)
    player = Replayer(legacy.FILE, bus, speed=100.0).start()
    assert player.wait(timeout=30)
    player.close()
    for name, r in legacy.readings().items():
        got = sensors[name].drain()
        assert [g.stamp_ns for g in got] == r.stamp_ns.tolist(), name
        assert np.array([[getattr(g, f) for f in r.message.__struct_fields__[1:]] for g in got]).tobytes() == \
            r.values.tobytes(), name
    assert cmds.drain() == [legacy.CMD]


def test_bad_speed_is_refused(recording):
    with pytest.raises(ValueError, match="positive factor"):
        Replayer(recording, LocalBus(), speed=0.0)


def test_replay_cli_plays_to_the_end_on_zenoh(recording):
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "replay", str(recording.path), "--speed", "50",
                        "--listen", "tcp/127.0.0.1:0"], stdin=subprocess.DEVNULL, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    played = sum(recording.count(n) for n in recording.topics if n not in NOT_PLAYED)
    assert r.stdout.splitlines()[-1] == f"vilma replay: {played} messages published"


def test_replay_republishes_camera_images_and_laser_scans(tmp_path):
    sent = write_world_recording(tmp_path / "w.mcap")
    bus = LocalBus()
    queues = {name: BoundedQueue(bus, topic(name), maxsize=100) for name in WORLD_TOPICS}
    player = Replayer(tmp_path / "w.mcap", bus, speed=50.0).start()
    assert player.wait(timeout=30)
    player.close()
    for name, q in queues.items():
        assert q.drain() == [msg for n, msg in sent if n == name]
    assert player.published == 3 * 25 + len(sent)  # and the poses, velocities and actuator states


@pytest.mark.parametrize("write", [write_layered_recording, write_old_layered_recording])
def test_replay_republishes_a_multi_layer_laser_as_recorded_now_and_before(tmp_path, write):
    sent = write(tmp_path / "l.mcap")
    bus = LocalBus()
    scans = BoundedQueue(bus, topic("laser"), maxsize=100)
    player = Replayer(tmp_path / "l.mcap", bus, speed=50.0).start()
    assert player.wait(timeout=30)
    player.close()
    assert scans.drain() == sent and player.published == len(sent)


def test_a_corrupt_image_is_skipped_with_a_warning(tmp_path, caplog):
    write_world_recording(tmp_path / "w.mcap", n=2)
    rec = read_recording(tmp_path / "w.mcap")
    rec.raw["camera/front_left"][1][0] = b'{"data": 1}'
    bus = LocalBus()
    images = BoundedQueue(bus, topic("camera/front_left"), maxsize=100)
    player = Replayer(rec, bus, speed=50.0).start()
    assert player.wait(timeout=30)
    player.close()
    assert [i.stamp_ns for i in images.drain()] == [2 * PERIOD_NS]
    assert any("does not decode" in r.getMessage() and "skipped" in r.getMessage() for r in caplog.records)
