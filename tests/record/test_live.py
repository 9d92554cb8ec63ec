"""``--foxglove``: a real WebSocket client speaking the Foxglove protocol gets the channels, messages and time."""

from __future__ import annotations

import base64
import json
import socket
import struct
import time

import pytest
from websockets.sync.client import connect

from tests.record.ros2 import ros2_decoder
from tests.record.world_messages import (
    PERIOD_NS,
    WORLD_SENSORS,
    WORLD_TOPICS,
    depth_image,
    red_square,
    wall_scan,
    world_at,
)
from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core import messages as m
from vilma.core.geometry import quaternion_from_euler
from vilma.record.live import FoxgloveLive
from vilma.record.sensor_frames import sensor_frame


@pytest.fixture
def live():
    bus = LocalBus()
    server = FoxgloveLive(bus, port=0)
    yield bus, server
    server.close()


def _json_until(ws, op: str) -> dict:
    while True:
        frame = ws.recv(timeout=10)
        if isinstance(frame, str) and json.loads(frame)["op"] == op:
            return json.loads(frame)


def test_a_foxglove_client_gets_channels_messages_and_sim_time(live):
    bus, server = live
    keys = {"pose": "vilma/vilma/pose", "tf": "vilma/vilma/tf", "euler": "vilma/vilma/pose/euler",
            "gps": "vilma/vilma/gps"}
    with connect(f"ws://127.0.0.1:{server.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
        info = _json_until(ws, "serverInfo")
        assert "time" in info["capabilities"]
        channels = {}
        while not set(keys.values()) <= set(channels):
            channels.update({c["topic"]: c for c in _json_until(ws, "advertise")["channels"]})
        assert [(channels[k]["schemaName"], channels[k]["schemaEncoding"], channels[k]["encoding"])
                for k in keys.values()] == [("geometry_msgs/msg/PoseStamped", "ros2msg", "cdr"),
                                            ("foxglove_msgs/msg/FrameTransform", "ros2msg", "cdr"),
                                            ("geometry_msgs/msg/Vector3Stamped", "ros2msg", "cdr"),
                                            ("sensor_msgs/msg/NavSatFix", "ros2msg", "cdr")]
        assert channels["vilma/vilma/driver/status"]["encoding"] == "json"
        decoders = {}
        for sub, name in enumerate(("pose", "tf"), 7):
            ch = channels[keys[name]]
            decoders[sub] = ros2_decoder(ch["schemaName"], ch["schema"])
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": sub, "channelId": channels[keys[name]]["id"]} for sub, name in enumerate(("pose", "tf"), 7)]}))

        deadline = time.monotonic() + 10
        got: dict[int, tuple[int, object]] = {}
        k = 0
        while len(got) < 2 and time.monotonic() < deadline:  # the subscription takes effect asynchronously
            k += 1
            pose = m.Pose(k * 20_000_000, 10.0 + k, -5.0, 0.0, 0.0, 0.0, 0.5)
            bus.publish(topic("pose"), pose)
            bus.publish(topic("sim/status"), m.SimStatus(stamp_ns=pose.stamp_ns))
            try:
                while True:
                    frame = ws.recv(timeout=0.05)
                    if isinstance(frame, bytes) and frame[0] == 0x01:
                        sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
                        got.setdefault(sub_id, (log_time, decoders[sub_id](frame[13:])))
            except TimeoutError:
                pass
        assert set(got) == {7, 8}, "no message came"
        for log_time, msg in got.values():
            stamp = msg.header.stamp if hasattr(msg, "header") else msg.timestamp
            assert log_time == stamp.sec * 10**9 + stamp.nanosec and log_time % 20_000_000 == 0
        log_time, pose = got[7]
        assert (pose.header.frame_id, pose.pose.position.x, pose.pose.position.y) == (
            "map", 10.0 + log_time // 20_000_000, -5.0)
        assert pose.pose.orientation.z == float(quaternion_from_euler(0.0, 0.0, 0.5)[2])
        log_time, tf = got[8]
        assert (tf.parent_frame_id, tf.child_frame_id, tf.translation.x) == ("map", "vilma",
                                                                           10.0 + log_time // 20_000_000)
        assert tf.rotation.z == pytest.approx(float(quaternion_from_euler(0.0, 0.0, 0.5)[2]))
        bus.publish(topic("sim/status"), m.SimStatus(stamp_ns=123_000_000_000))
        while True:  # the server's clock follows sim time
            frame = ws.recv(timeout=10)
            if isinstance(frame, bytes) and frame[0] == 0x02 and struct.unpack_from("<Q", frame, 1)[0] == 123 * 10**9:
                break


def test_up_serves_foxglove_and_run_needs_realtime():
    from vilma.app import programs
    from vilma.app.batch import BUNDLED
    from vilma.app.record import foxglove_observer
    from vilma.scenario import load_scenario

    lines: list[str] = []
    assert programs.up(load_scenario(BUNDLED / "course_30kmh_stanley.yaml"), 50.0, 0.5, lines.append,
                       foxglove=0) == 0
    assert lines[0].startswith("Foxglove: open connection ws://127.0.0.1:")
    with pytest.raises(ValueError, match="--realtime"):
        foxglove_observer(0, None, print)



def test_world_sensors_are_served_in_foxglove_schemas():
    bus = LocalBus()
    server = FoxgloveLive(bus, port=0, world_topics=WORLD_TOPICS)
    keys = [f"vilma/vilma/{n}" for n in WORLD_TOPICS]
    got: dict[int, dict] = {}
    try:
        with connect(f"ws://127.0.0.1:{server.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
            _json_until(ws, "serverInfo")
            channels: dict = {}
            while not set(keys) <= set(channels):
                channels.update({c["topic"]: c for c in _json_until(ws, "advertise")["channels"]})
            assert [channels[k]["schemaName"] for k in keys] == [
                "foxglove.CompressedImage", "foxglove.RawImage", "foxglove.PointCloud"]
            assert {channels[k]["schemaEncoding"] for k in keys} == {"jsonschema"}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": channels[k]["id"]} for i, k in enumerate(keys)]}))
            deadline = time.monotonic() + 10
            k = 0
            while len(got) < len(keys) and time.monotonic() < deadline:  # subscriptions take effect asynchronously
                k += 1
                for name, msg in world_at(k * PERIOD_NS):
                    bus.publish(topic(name), msg)
                try:
                    while True:
                        frame = ws.recv(timeout=0.05)
                        if isinstance(frame, bytes) and frame[0] == 0x01:
                            got[struct.unpack_from("<I", frame, 1)[0]] = json.loads(frame[13:])
                except TimeoutError:
                    pass
            good = red_square()
            bus.publish(topic("camera/front_left"), m.Image(1, "c", 2, 2, "rgb8", 6, good.data))  # torn: dropped
    finally:
        server.close()
    assert server.dropped == {"camera/front_left": 1}
    jpeg, depth, laser = got[0], got[1], got[2]
    assert jpeg["format"] == "jpeg" and base64.b64decode(jpeg["data"])[:2] == b"\xff\xd8"
    assert base64.b64decode(depth["data"]) == depth_image(width=160, height=120).data and depth["encoding"] == "32FC1"
    assert base64.b64decode(laser["data"]) == wall_scan().points and laser["point_stride"] == 12


def _static_frames(port: int) -> tuple[list[int], list[object]]:
    """Log times [ns] and messages a new client gets on ``tf_static`` within a second of subscribing to it."""
    with connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
        channels: dict = {}
        while "vilma/vilma/tf_static" not in channels:
            channels.update({c["topic"]: c for c in _json_until(ws, "advertise")["channels"]})
        ch = channels["vilma/vilma/tf_static"]
        decode = ros2_decoder(ch["schemaName"], ch["schema"])
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [{"id": 5, "channelId": ch["id"]}]}))
        times, got = [], []
        try:
            while True:
                frame = ws.recv(timeout=1)
                if isinstance(frame, bytes) and frame[0] == 0x01 and struct.unpack_from("<I", frame, 1)[0] == 5:
                    times.append(struct.unpack_from("<Q", frame, 5)[0])
                    got.append(decode(frame[13:]))
        except TimeoutError:
            return times, got


def test_each_client_subscribing_to_tf_static_gets_the_sensors_mounts():
    bus = LocalBus()
    server = FoxgloveLive(bus, port=0, world_topics=WORLD_TOPICS, world_sensors=WORLD_SENSORS)
    try:
        first = _static_frames(server.port)
        bus.publish(topic("sim/status"), m.SimStatus(stamp_ns=3_000_000_000))
        second = _static_frames(server.port)  # a later client, after the sim time went on
    finally:
        server.close()
    for (times, got), now in ((first, 0), (second, 3_000_000_000)):
        assert times == [now] * len(WORLD_SENSORS)  # logged at the latest sim time, stamped at its start
        assert [(t.timestamp.sec, t.timestamp.nanosec, t.parent_frame_id, t.child_frame_id) for t in got] == [
            (0, 0, "vilma", s.name) for s in WORLD_SENSORS]
        assert [(t.translation.x, t.translation.y, t.translation.z) for t in got] == [
            s.position for s in WORLD_SENSORS]
        assert [(t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w) for t in got] == [
            sensor_frame(s, "vilma").rotation for s in WORLD_SENSORS]  # as recorded (test_sensor_frames.py)


def test_a_live_server_without_world_sensors_has_no_tf_static():
    server = FoxgloveLive(LocalBus(), port=0, world_topics=WORLD_TOPICS)
    try:
        with connect(f"ws://127.0.0.1:{server.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
            channels: dict = {}
            while "vilma/vilma/laser" not in channels:
                channels.update({c["topic"]: c for c in _json_until(ws, "advertise")["channels"]})
            assert "vilma/vilma/tf_static" not in channels
    finally:
        server.close()


def test_a_live_server_in_a_with_block_stops_listening_even_when_the_block_raises():
    with pytest.raises(RuntimeError, match="boom"), FoxgloveLive(LocalBus(), port=0) as live:
        assert isinstance(live, FoxgloveLive)
        socket.create_connection(("127.0.0.1", live.port), timeout=5).close()  # it listens
        raise RuntimeError("boom")
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", live.port), timeout=5).close()


def test_a_live_run_view_in_a_with_block_stops_listening_even_when_the_block_raises():
    from vilma.app.record import foxglove_observer

    with pytest.raises(RuntimeError, match="boom"), foxglove_observer(0, 1.0, print) as live:
        socket.create_connection(("127.0.0.1", live.server.port), timeout=5).close()  # it listens
        raise RuntimeError("boom")
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", live.server.port), timeout=5).close()
