"""A road run's recording and live view hold the road and the traffic as Foxglove scene primitives, the traffic
where the run has it: as the file recorded it, or where reactive traffic drove."""

from __future__ import annotations

import dataclasses
import json
import math
import struct
import threading
import time

import numpy as np
import pytest
from mcap.reader import make_reader

from tests.world.test_commonroad import TUTORIAL, _lanelets
from tests.world.test_road_view import _obstacle
from vilma.app.batch import find_scenario
from vilma.record.reader import read_recording
from vilma.record.run import record_run
from vilma.scenario.spec import load_scenario


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """The tutorial run for 2 s of sim time, recorded: its scenario and the scene messages by topic."""
    sc = dataclasses.replace(load_scenario(find_scenario("commonroad_tutorial")), duration=2.0)
    out = tmp_path_factory.mktemp("run")
    record_run(sc, out)
    scenes: dict[str, list] = {}
    with (out / "run.mcap").open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if schema.name == "foxglove.SceneUpdate":
                scenes.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
    assert read_recording(out / "run.mcap").complete  # the reader takes the scene channels in its stride
    return sc, scenes


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z of the cross products of the rows of ``a`` and ``b`` (n, 2)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _xy(points: list[dict]) -> np.ndarray:
    return np.array([(p["x"], p["y"]) for p in points])


def test_the_road_is_recorded_once_with_the_files_lanelet_vertices(recorded):
    _, scenes = recorded
    ((stamp, road),) = scenes["vilma/vilma/road"]
    assert stamp == 0
    lanes = _lanelets(TUTORIAL)
    entities = {e["id"]: e for e in road["entities"]}
    assert set(entities) == {f"lanelet/{i}" for i in lanes} | {"goal"}
    for i, (left, right) in lanes.items():
        e = entities[f"lanelet/{i}"]
        assert e["frame_id"] == "map"
        (lt, rt) = e["lines"]
        np.testing.assert_array_equal(_xy(lt["points"]), left)
        np.testing.assert_array_equal(_xy(rt["points"]), right)
        (surface,) = e["triangles"]
        idx = np.array(surface["indices"]).reshape(-1, 3)
        assert len(idx) == 2 * (len(left) - 1)  # two triangles between each pair of boundary points
        pts = _xy(surface["points"])[idx]
        area = 0.5 * np.abs(_cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0])).sum()
        outline = np.vstack([left, right[::-1]])  # the shoelace area of the lanelet's outline
        assert area == pytest.approx(0.5 * abs(_cross(outline, np.roll(outline, -1, axis=0)).sum()), rel=1e-9)


def test_the_traffic_is_recorded_a_file_step_as_boxes_where_the_file_has_them(recorded):
    sc, scenes = recorded
    frames = scenes["vilma/vilma/traffic"]
    dt, k0 = sc.road.dt, sc.road.time_step
    assert [s for s, _ in frames] == [round(k * dt * 1e9) for k in range(len(frames))]
    assert (len(frames) - 1) * dt == pytest.approx(sc.duration, abs=dt)
    length, width, states = _obstacle(TUTORIAL, "dynamicObstacle")
    for (stamp, update), (k, x, y, yaw) in zip(frames, [s for s in states if s[0] >= k0], strict=False):
        assert stamp == round((k - k0) * dt * 1e9)
        assert update["deletions"][0]["type"] == 1  # the previous frame's boxes go
        ((cube,),) = [e["cubes"] for e in update["entities"] if e["id"] == "obstacle/42"]
        p, q = cube["pose"]["position"], cube["pose"]["orientation"]
        assert (p["x"], p["y"]) == pytest.approx((x, y), abs=1e-9)
        assert 2 * math.atan2(q["z"], q["w"]) == pytest.approx(yaw, abs=1e-9)
        assert (cube["size"]["x"], cube["size"]["y"]) == pytest.approx((length, width))


def test_a_foxglove_client_gets_the_road_and_the_moving_traffic():
    from websockets.sync.client import connect

    from tests.record.test_live import _json_until
    from vilma.bus.local import LocalBus
    from vilma.bus.topics import topic
    from vilma.core.messages import SimStatus
    from vilma.record.live import FoxgloveLive
    from vilma.world.road_view import road_view

    task = load_scenario(find_scenario("commonroad_tutorial")).road
    _, _, states = _obstacle(TUTORIAL, "dynamicObstacle")
    bus = LocalBus()
    server = FoxgloveLive(bus, port=0, road=road_view(task))
    try:
        with connect(f"ws://127.0.0.1:{server.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
            channels = {}
            while not {"vilma/vilma/road", "vilma/vilma/traffic"} <= set(channels):
                channels.update({c["topic"]: c for c in _json_until(ws, "advertise")["channels"]})
            assert channels["vilma/vilma/road"]["schemaName"] == "foxglove.SceneUpdate"
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": 1, "channelId": channels["vilma/vilma/road"]["id"]},
                {"id": 2, "channelId": channels["vilma/vilma/traffic"]["id"]}]}))
            got: dict[int, list] = {1: [], 2: []}
            k = 0
            while len(got[2]) < 3 or not got[1]:  # the subscription takes effect asynchronously
                assert k < 500, "no scene came"
                bus.publish(topic("sim/status"), SimStatus(stamp_ns=round(k * task.dt * 1e9)))
                k += 1
                try:
                    while True:
                        frame = ws.recv(timeout=0.05)
                        if isinstance(frame, bytes) and frame[0] == 0x01:
                            sub, log_time = struct.unpack_from("<IQ", frame, 1)
                            got[sub].append((log_time, json.loads(frame[13:])))
                except TimeoutError:
                    pass
    finally:
        server.close()
        bus.close()
    lanes = _lanelets(TUTORIAL)
    road = {e["id"]: e for e in got[1][0][1]["entities"]}
    for i, (left, right) in lanes.items():
        np.testing.assert_array_equal(_xy(road[f"lanelet/{i}"]["lines"][0]["points"]), left)
        np.testing.assert_array_equal(_xy(road[f"lanelet/{i}"]["lines"][1]["points"]), right)
    for log_time, update in got[2]:  # each at a status's time, one file step apart: the file's states
        step = round(log_time / 1e9 / task.dt)
        _, x, y, _ = states[step]
        p = update["entities"][0]["cubes"][0]["pose"]["position"]
        assert (p["x"], p["y"]) == pytest.approx((x, y), abs=1e-9)
    assert np.all(np.diff([t for t, _ in got[2]]) == round(task.dt * 1e9))


def test_up_records_the_road_at_the_start(tmp_path):
    from vilma.app import programs

    sc = load_scenario(find_scenario("commonroad_tutorial"))
    assert programs.up(sc, 50.0, 0.2, lambda _: None, record=tmp_path / "up.mcap") == 0
    with (tmp_path / "up.mcap").open("rb") as f:
        ((_, _, road),) = make_reader(f).iter_messages(topics=["vilma/vilma/road"])
    assert road.log_time == 0
    ids = {e["id"] for e in json.loads(road.data)["entities"]}
    assert ids == {f"lanelet/{i}" for i in _lanelets(TUTORIAL)} | {"goal"}


def test_up_records_the_traffic_a_file_step_where_the_file_has_it(tmp_path):
    from vilma.app import programs

    sc = load_scenario(find_scenario("commonroad_tutorial"))
    assert programs.up(sc, 50.0, 1.0, lambda _: None, record=tmp_path / "up.mcap") == 0
    with (tmp_path / "up.mcap").open("rb") as f:
        frames = [(m.log_time, json.loads(m.data)) for _, _, m in make_reader(f).iter_messages(
            topics=["vilma/vilma/traffic"])]
    dt, k0 = sc.road.dt, sc.road.time_step
    assert len(frames) >= round(0.9 / dt)
    assert [s for s, _ in frames] == [round(k * dt * 1e9) for k in range(len(frames))]
    _, _, states = _obstacle(TUTORIAL, "dynamicObstacle")
    for (_, update), (_, x, y, _) in zip(frames, [s for s in states if s[0] >= k0], strict=False):
        ((cube,),) = [e["cubes"] for e in update["entities"] if e["id"] == "obstacle/42"]
        assert (cube["pose"]["position"]["x"], cube["pose"]["position"]["y"]) == pytest.approx((x, y), abs=1e-9)


def _live_scenes(ws, run: threading.Thread) -> dict[str, list]:
    """The scene updates (log time, JSON) by topic a Foxglove client gets while ``run`` goes; it subscribes to
    the road and the traffic once they are advertised, and again (new ids) while a topic has sent nothing for a
    second (a subscription the server refused or lost: its answers are kept under ``status``)."""
    channels: dict[str, dict] = {}
    got: dict[str, list] = {}
    names: dict[int, str] = {}  # subscription id -> topic
    asked = -math.inf  # when the last subscription was sent (monotonic s)
    while True:
        try:
            frame = ws.recv(timeout=0.5)
        except TimeoutError:
            frame = None
            if not run.is_alive():
                return got
        if isinstance(frame, str):
            msg = json.loads(frame)
            if msg.get("op") == "status":
                got.setdefault("status", []).append(msg)
            if msg.get("op") == "advertise":
                channels.update({c["topic"]: c for c in msg["channels"]})
        elif isinstance(frame, bytes) and frame[0] == 0x01:
            sub, log_time = struct.unpack_from("<IQ", frame, 1)
            got.setdefault(names[sub], []).append((log_time, json.loads(frame[13:])))
        missing = [t for t in ("road", "traffic") if t not in got]
        if missing and {f"vilma/vilma/{t}" for t in missing} <= set(channels) and time.monotonic() - asked > 1.0:
            subs = []
            for t in missing:
                names[len(names)] = t
                subs.append({"id": len(names) - 1, "channelId": channels[f"vilma/vilma/{t}"]["id"]})
            ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
            asked = time.monotonic()


@pytest.fixture(scope="module")
def reactive_live(tmp_path_factory):
    """A reactive run (the recorded car brakes behind the slow ego), at 2x real time, recorded and shown live
    as ``vilma run --realtime 2 --foxglove`` does: the recorded scenario, the result, the scene updates of the
    recording and of a Foxglove client, by topic."""
    from websockets.sync.client import connect

    from tests.scenario.test_reactive_traffic import _scenario
    from vilma.app.record import foxglove_observer

    sc = dataclasses.replace(_scenario(tmp_path_factory.mktemp("s"), "traffic: reactive"), duration=6.0)
    out, results = tmp_path_factory.mktemp("run"), []
    with foxglove_observer(0, 2.0, print) as live, connect(
            f"ws://127.0.0.1:{live.server.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
        run = threading.Thread(target=lambda: results.append(record_run(sc, out, realtime=2.0,
                                                                        observers=live.watch(sc))))
        run.start()
        shown = _live_scenes(ws, run)
        run.join()
    recorded: dict[str, list] = {}
    with (out / "run.mcap").open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if schema.name == "foxglove.SceneUpdate":
                recorded.setdefault(channel.topic.rsplit("/", 1)[1], []).append(
                    (message.log_time, json.loads(message.data)))
    return sc, results[0], recorded, shown


def _car_xy(update: dict) -> tuple[float, float]:
    ((cube,),) = [e["cubes"] for e in update["entities"]]
    return cube["pose"]["position"]["x"], cube["pose"]["position"]["y"]


def _check_where_it_drove(sc, result, frames: list, abs_m: float) -> None:
    """Each traffic frame draws the car where the run drove it (``result``'s traffic, as scored), which is at
    least 2 m behind where the file recorded it in some frame (the views would draw the recording)."""
    from vilma.world.road_view import road_view

    drove, file = road_view(result.scenario.road), road_view(sc.road)
    behind = 0.0
    for stamp, update in frames:
        (car,), (rec,) = drove.at(stamp * 1e-9), file.at(stamp * 1e-9)
        assert _car_xy(update) == pytest.approx(tuple(car.pose[:2]), abs=abs_m)
        behind = max(behind, rec.pose[0] - car.pose[0])
    assert behind > 2.0


@pytest.mark.slow
def test_a_reactive_runs_recording_draws_the_traffic_where_it_drove(reactive_live):
    sc, result, recorded, _ = reactive_live
    assert result.metrics["traffic"] == "reactive"
    frames = recorded["traffic"]
    assert len(frames) >= round(sc.duration / sc.road.dt)
    _check_where_it_drove(sc, result, frames, 1e-9)  # at the file's steps: exactly the scored states


@pytest.mark.slow
def test_vilma_run_foxglove_shows_the_road_and_the_reactive_traffic(reactive_live):
    sc, result, _, shown = reactive_live
    lanes = _lanelets(TUTORIAL)
    # the client subscribes once the channels are advertised, so it may miss the first frames (the road comes
    # again every ROAD_REPEAT_S): 6 s of sim time leave it several of each under any load
    assert shown.get("road"), f"no road shown; got {sorted(shown)}"
    assert {e["id"] for e in shown["road"][0][1]["entities"]} == {f"lanelet/{i}" for i in lanes} | {"goal"}
    assert len(shown.get("traffic", ())) >= 5, f"traffic frames shown: {len(shown.get('traffic', ()))}; " \
                                               f"the server said: {shown.get('status')}"
    # at a status's time, between the file's steps: linear between the scored states (IDM's braking of at
    # most ~4 m/s^2 bends the path by a dt^2 / 8 < 5 mm within a file step of 0.1 s)
    _check_where_it_drove(sc, result, shown["traffic"], 0.01)
