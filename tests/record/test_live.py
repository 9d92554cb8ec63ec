"""``--foxglove``: a real WebSocket client speaking the Foxglove protocol gets the channels, messages and time."""

from __future__ import annotations

import json
import socket
import struct
import time

import pytest
from websockets.sync.client import connect

from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core import messages as m
from vilma.core.geometry import quaternion_from_euler
from vilma.record.live import FoxgloveLive


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def live():
    bus = LocalBus()
    server = FoxgloveLive(bus, port=_free_port())
    yield bus, server
    server.close()


def _json_until(ws, op: str) -> dict:
    while True:
        frame = ws.recv(timeout=10)
        if isinstance(frame, str) and json.loads(frame)["op"] == op:
            return json.loads(frame)


def test_a_foxglove_client_gets_channels_messages_and_sim_time(live):
    bus, server = live
    with connect(f"ws://127.0.0.1:{server.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
        info = _json_until(ws, "serverInfo")
        assert "time" in info["capabilities"]
        channels = {}
        while not {"vilma/vilma/pose", "vilma/vilma/gps", "vilma/vilma/tf"} <= set(channels):
            channels.update({c["topic"]: c for c in _json_until(ws, "advertise")["channels"]})
        assert channels["vilma/vilma/pose"]["schemaName"] == "foxglove.PoseInFrame"
        assert channels["vilma/vilma/gps"]["schemaName"] == "foxglove.LocationFix"
        assert channels["vilma/vilma/tf"]["schemaName"] == "foxglove.FrameTransform"
        assert channels["vilma/vilma/pose"]["encoding"] == "json"
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 7, "channelId": channels["vilma/vilma/pose"]["id"]}]}))

        deadline = time.monotonic() + 10
        got = None
        k = 0
        while got is None and time.monotonic() < deadline:  # the subscription takes effect asynchronously
            k += 1
            pose = m.Pose(k * 20_000_000, 10.0 + k, -5.0, 0.0, 0.0, 0.0, 0.5)
            bus.publish(topic("pose"), pose)
            bus.publish(topic("sim/status"), m.SimStatus(stamp_ns=pose.stamp_ns))
            try:
                while True:
                    frame = ws.recv(timeout=0.05)
                    if isinstance(frame, bytes) and frame[0] == 0x01:
                        got = frame
                        break
            except TimeoutError:
                pass
        assert got is not None, "no message came"
        sub_id, log_time = struct.unpack_from("<IQ", got, 1)
        body = json.loads(got[13:])
        assert sub_id == 7
        assert log_time == body["stamp_ns"] and log_time % 20_000_000 == 0
        k = log_time // 20_000_000
        assert body["x"] == 10.0 + k and body["pose"]["position"]["x"] == 10.0 + k
        assert body["pose"]["orientation"]["z"] == pytest.approx(float(quaternion_from_euler(0.0, 0.0, 0.5)[2]))
        bus.publish(topic("sim/status"), m.SimStatus(stamp_ns=123_000_000_000))
        while True:  # the server's clock follows sim time
            frame = ws.recv(timeout=10)
            if isinstance(frame, bytes) and frame[0] == 0x02 and struct.unpack_from("<Q", frame, 1)[0] == 123 * 10**9:
                break


def test_up_serves_foxglove_and_run_needs_realtime():
    from vilma import programs
    from vilma.record.commands import foxglove_observer
    from vilma.scenario import load_scenario
    from vilma.scenario.batch import BUNDLED

    lines: list[str] = []
    assert programs.up(load_scenario(BUNDLED / "course_30kmh_stanley.yaml"), 50.0, 0.5, lines.append,
                       foxglove=_free_port()) == 0
    assert lines[0].startswith("Foxglove: open connection ws://127.0.0.1:")
    with pytest.raises(ValueError, match="--realtime"):
        foxglove_observer(0, None, print)
