"""A planned car's tracks and plans are recorded and served live beside their topics as Foxglove scene primitives:
the tracks' boxes, velocity arrows and ids, the trajectory chosen, the candidates by status, the predictions."""

from __future__ import annotations

import functools
import json
import math
import struct
import time

import numpy as np
from mcap.reader import make_reader
from websockets.sync.client import connect

from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core.messages import LocalPlan, TrackList
from vilma.perception import Track, predict
from vilma.planning import FrenetFrame, FrenetState, PlannerParams, local_plan, plan, track_list
from vilma.record.live import FoxgloveLive
from vilma.record.plan_scene import ARROW_S, LIFETIME_S, STATUS_NAMES, TRACK_HEIGHT
from vilma.record.reader import read_recording
from vilma.record.recorder import BusRecorder, Recorder
from vilma.record.road_scene import DELETE_ALL
from vilma.trajectory import Trajectory

STAMP_NS = 2_500_000_000
SCENES = ("perception/objects/scene", "planning/plan/scene")


@functools.cache
def planned_cycle() -> tuple[TrackList, LocalPlan]:
    """A planning cycle on a straight road at 15 m/s behind a standing lead (track 7, 4.5 m x 1.8 m at x 25 m,
    yaw 0), with a car crossing ahead at 1 m/s (track 9, yaw pi/2; two futures, straight on and along a lane that
    turns right): free, infeasible and colliding candidates."""
    tracks = [Track(7, 25.0, 0.0, 0.0, 0.0, 0.0, 4.5, 1.8, np.diag([0.1, 0.2, 0.3, 0.4]), 2.5),
              Track(9, 20.0, 6.0, math.pi / 2, 0.0, 1.0, 4.0, 2.0, np.eye(4), 1.0)]
    futures = [*tracks, tracks[1]]
    p = PlannerParams()
    boxes = predict(futures, p.times, [None, None, Trajectory.from_points([(20.0, 5.0), (20.0, 7.0), (30.0, 7.0)])])
    cycle = plan(FrenetState(0.0, 15.0, 0.0, 0.0), FrenetFrame(Trajectory.from_points([(0.0, 0.0), (1000.0, 0.0)])),
                 boxes, p)
    return track_list(STAMP_NS, "truth", tracks), local_plan(STAMP_NS, cycle, futures, boxes)


def _xy(points: list[dict]) -> np.ndarray:
    return np.array([(p["x"], p["y"]) for p in points])


def _yaw(q: dict) -> float:
    return 2 * math.atan2(q["z"], q["w"])


def _check_update(update: dict, ids: set[str]) -> dict[str, dict]:
    """``update`` deletes the previous one's entities and holds entities ``ids``, each lasting the lifetime."""
    assert update["deletions"] == [{"timestamp": {"sec": 2, "nsec": 500_000_000}, "type": DELETE_ALL, "id": ""}]
    entities = {e["id"]: e for e in update["entities"]}
    assert set(entities) == ids
    for e in entities.values():
        assert e["frame_id"] == "map" and e["lifetime"]["sec"] + e["lifetime"]["nsec"] * 1e-9 == LIFETIME_S
    return entities


def check_tracks_scene(update: dict, tracks: TrackList) -> None:
    """Each track a box at its centre, yaw and size, an arrow from its centre along its velocity as long as its
    travel in :data:`ARROW_S`, and its id."""
    entities = _check_update(update, {f"track/{o.id}" for o in tracks.objects})
    for o in tracks.objects:
        e = entities[f"track/{o.id}"]
        (cube,), (arrow,), (text,) = e["cubes"], e["arrows"], e["texts"]
        pos = cube["pose"]["position"]
        assert (pos["x"], pos["y"], pos["z"]) == (o.x, o.y, TRACK_HEIGHT / 2)
        assert math.isclose(_yaw(cube["pose"]["orientation"]), o.yaw, abs_tol=1e-12)
        assert (cube["size"]["x"], cube["size"]["y"]) == (o.length, o.width)
        assert (arrow["pose"]["position"]["x"], arrow["pose"]["position"]["y"]) == (o.x, o.y)
        assert math.isclose(arrow["shaft_length"] + arrow["head_length"], math.hypot(o.vx, o.vy) * ARROW_S)
        if o.vx or o.vy:
            assert math.isclose(_yaw(arrow["pose"]["orientation"]), math.atan2(o.vy, o.vx), abs_tol=1e-12)
        assert text["text"] == str(o.id)


def check_plan_scene(update: dict, cycle: LocalPlan) -> None:
    """The chosen trajectory through the plan's points, thicker than the candidates, one line a candidate under its
    status, and each prediction through its points."""
    statuses = {STATUS_NAMES[c.status] for c in cycle.candidates}
    entities = _check_update(update, {"plan/chosen", *(f"plan/candidates/{s}" for s in statuses),
                                      *(f"prediction/{p.id}" for p in cycle.predictions)})
    (chosen,) = entities["plan/chosen"]["lines"]
    np.testing.assert_array_equal(_xy(chosen["points"]), np.column_stack([cycle.x, cycle.y]))
    for status, name in enumerate(STATUS_NAMES):
        lines = entities.get(f"plan/candidates/{name}", {"lines": []})["lines"]
        want = [np.column_stack([c.x, c.y]) for c in cycle.candidates if c.status == status]
        assert len(lines) == len(want)
        for line, xy in zip(lines, want, strict=True):
            np.testing.assert_array_equal(_xy(line["points"]), xy)
            assert line["thickness"] < chosen["thickness"]
    for i in {p.id for p in cycle.predictions}:  # a track's futures, in order
        lines, want = entities[f"prediction/{i}"]["lines"], [p for p in cycle.predictions if p.id == i]
        assert len(lines) == len(want)
        for line, p in zip(lines, want, strict=True):
            np.testing.assert_array_equal(_xy(line["points"]), np.column_stack([p.x, p.y]))


def test_the_cycle_has_every_kind_of_candidate():
    _, cycle = planned_cycle()
    assert {c.status for c in cycle.candidates} == {0, 1, 2}  # so that the tests below see every kind drawn


def test_a_bus_recording_draws_the_tracks_and_the_plan_beside_their_messages(tmp_path):
    tracks, cycle = planned_cycle()
    bus = LocalBus()
    recording = BusRecorder(bus, Recorder(tmp_path / "p.mcap"))
    bus.publish(topic("perception/objects"), tracks)
    bus.publish(topic("planning/plan"), cycle)
    recording.close()

    scenes: dict[str, list] = {}
    with (tmp_path / "p.mcap").open("rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if schema.name == "foxglove.SceneUpdate":
                scenes.setdefault(channel.topic, []).append((message.log_time, json.loads(message.data)))
    ((t_tracks, tracks_update),) = scenes.pop("vilma/vilma/perception/objects/scene")
    ((t_plan, plan_update),) = scenes.pop("vilma/vilma/planning/plan/scene")
    assert scenes == {} and t_tracks == t_plan == STAMP_NS
    check_tracks_scene(tracks_update, tracks)
    check_plan_scene(plan_update, cycle)
    back = read_recording(tmp_path / "p.mcap")
    assert back.complete and back.messages("perception/objects") == [tracks]
    assert back.messages("planning/plan") == [cycle]


def test_a_foxglove_client_gets_the_tracks_and_the_plan_as_scenes():
    tracks, cycle = planned_cycle()
    bus = LocalBus()
    server = FoxgloveLive(bus, port=0)
    keys = [f"vilma/vilma/{s}" for s in SCENES]
    got: dict[int, dict] = {}
    try:
        with connect(f"ws://127.0.0.1:{server.port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"]) as ws:
            channels: dict = {}
            while not set(keys) <= set(channels):
                frame = ws.recv(timeout=10)
                if isinstance(frame, str) and json.loads(frame)["op"] == "advertise":
                    channels.update({c["topic"]: c for c in json.loads(frame)["channels"]})
            assert {channels[k]["schemaName"] for k in keys} == {"foxglove.SceneUpdate"}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": channels[k]["id"]} for i, k in enumerate(keys)]}))
            deadline = time.monotonic() + 10
            while len(got) < len(keys) and time.monotonic() < deadline:  # subscriptions take effect asynchronously
                bus.publish(topic("perception/objects"), tracks)
                bus.publish(topic("planning/plan"), cycle)
                try:
                    while True:
                        frame = ws.recv(timeout=0.05)
                        if isinstance(frame, bytes) and frame[0] == 0x01:
                            sub, log_time = struct.unpack_from("<IQ", frame, 1)
                            assert log_time == STAMP_NS
                            got[sub] = json.loads(frame[13:])
                except TimeoutError:
                    pass
    finally:
        server.close()
    assert set(got) == {0, 1}, "no scene came"
    check_tracks_scene(got[0], tracks)
    check_plan_scene(got[1], cycle)
