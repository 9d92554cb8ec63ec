"""Recording a car's topics to MCAP: from a bus (live programs) or from a run's arrays (``vilma run``).

:class:`Recorder` turns vilma messages and reading arrays into channels of an
:class:`~vilma.record.mcap_file.McapFile` (layouts in :mod:`vilma.record.schemas`).
A recording that cannot go on (unwritable path, full disk) says so in one line
through ``on_error`` and then drops what comes: the drive goes on. Camera images and
laser scans go in as :mod:`vilma.record.world_cdr` lays them out; a malformed one is
dropped with a one-line warning (the first of each topic). The world sensors' mounts go in first, on
``tf_static`` at sim time 0 (:mod:`vilma.record.sensor_frames`).
:class:`BusRecorder` subscribes to every topic of a car on a bus, and to the world
sensors' topics it is given.
"""

from __future__ import annotations

import json
import logging
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from vilma.bus.base import Bus
from vilma.bus.topics import SENSOR_TOPICS, TOPICS, topic
from vilma.core.closing import Closeable
from vilma.core.messages import Message
from vilma.record.mcap_file import ChunkPolicy, McapFile, RecordError
from vilma.record.plan_scene import PLANNING_SCENES, scene_json
from vilma.record.road_scene import (
    ROAD,
    SCENE_SCHEMA,
    SCENE_TOPICS,
    SCENE_UPDATE,
    TRAFFIC,
    TrafficFrames,
    road_scene,
)
from vilma.record.schemas import (
    DRIVE_LOG,
    FRAME_TRANSFORM,
    FRAME_TRANSFORM_SCHEMA,
    TF_STATIC,
    channels,
    encode_struct,
    numeric_layouts,
    struct_schema,
)
from vilma.record.sensor_frames import encode_frame, sensor_frames
from vilma.record.world_cdr import SCHEMAS, WorldChannels, WorldSensorParams, sensor_topics, world_channels
from vilma.record.world_schemas import (
    WorldMessageError,
    check_jpeg_quality,
    check_world_topics,
    note_dropped,
)
from vilma.sensors import Readings

if TYPE_CHECKING:  # the roads extra, which only a road scenario needs
    from vilma.world.road_view import RoadView

log = logging.getLogger(__name__)

LIVE_TOPICS = tuple(n for n in TOPICS if n != "sim/cmd")
"""Topics a live recording subscribes to: every topic of the car but ``sim/cmd`` (orders on ``*/cmd`` are
requests; the driver publishes those it took on ``driver/cmd``, which say what its task was)."""


def _stderr(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


class Recorder(Closeable):
    """One MCAP recording of car ``car`` (see the module docstring); ``source`` says which program made it.

    ``jpeg_quality`` (1..95) records colour camera images as JPEG; None (the default) records them raw, exact
    (about as small once the chunks are compressed, for vilma's flat-shaded renders: :mod:`vilma.record.world_cdr`).
    ``world_sensors``: the parameters of the cameras and laser whose messages will come (a camera's give its
    ``camera_info``, a laser's its scans' angles and limits; their mounts are written on ``tf_static`` at once).
    """

    def __init__(self, path: Path, car: str = "vilma", source: str = "vilma", policy: ChunkPolicy = ChunkPolicy(),
                 on_error: Callable[[str], None] = _stderr, jpeg_quality: int | None = None,
                 world_sensors: tuple[WorldSensorParams, ...] = ()) -> None:
        self.path, self.car, self.on_error, self.policy = Path(path), car, on_error, policy
        self.jpeg_quality = check_jpeg_quality(jpeg_quality)
        self._sensors = sensor_topics(world_sensors)
        self.error: str | None = None
        self.dropped: dict[str, int] = {}
        """Malformed world-sensor messages dropped, by topic."""
        self._layouts = numeric_layouts(car)
        self._world: dict[str, WorldChannels] = {}
        self._world_types: dict[str, str] = {}  # each world topic and those beside them -> ROS 2 type
        self._channels: dict[str, int] = {}
        self._lock = threading.Lock()
        self._file: McapFile | None = None
        try:
            self._file = McapFile(self.path, policy, profile="")
            self._file.add_metadata("vilma", {"car": car, "source": source, "time": "sim time, ns since the start",
                                              "frames": "ENU map; yaw counter-clockwise from east"})
            frames = sensor_frames(world_sensors, car)
            for k, frame in enumerate(frames, 1):
                self._file.write(self._channel(self._file, TF_STATIC), 0, encode_frame(frame),
                                 close_chunk=k == len(frames))
        except RecordError as e:
            self._stop(e)

    @property
    def ok(self) -> bool:
        """Whether the recording is still going."""
        return self._file is not None

    def _stop(self, e: RecordError) -> None:
        self.error = f"{e}; the drive goes on without recording"
        if self._file is not None:
            self._file.closed = True
        self._file = None
        self.on_error(self.error)

    def _guard(self, fn: Callable[[McapFile], None]) -> None:
        with self._lock:
            if self._file is None:
                return
            try:
                fn(self._file)
            except RecordError as e:
                self._stop(e)

    def _channel(self, f: McapFile, name: str) -> int:
        cid = self._channels.get(name)
        if cid is None:
            key = f"vilma/{self.car}/{name}"
            if name in self._layouts:
                lay = self._layouts[name]
                cid = f.add_channel(key, lay.schema_name, lay.schema, encoding="cdr")
            elif name in self._world_types:
                kind = self._world_types[name]
                cid = f.add_channel(key, kind, SCHEMAS[kind], encoding="cdr")
            elif name == TF_STATIC:
                cid = f.add_channel(key, FRAME_TRANSFORM, FRAME_TRANSFORM_SCHEMA, encoding="cdr")
            elif name in SCENE_TOPICS or name in PLANNING_SCENES:
                cid = f.add_channel(key, SCENE_UPDATE, SCENE_SCHEMA)
            else:
                cid = f.add_channel(key, f"vilma.{TOPICS[name].__name__}", struct_schema(TOPICS[name]))
            self._channels[name] = cid
        return cid

    # -- what to record ----------------------------------------------------------------------------------------

    def add_readings(self, readings: dict[str, Readings]) -> None:
        """Sensor readings (arrays) of one stretch of sim time, and the topics written beside them
        (:data:`~vilma.record.schemas.COMPANIONS`)."""
        batches = [(c, r.stamp_ns, r.values) for name, r in readings.items() if len(r) and name in self._layouts
                   for c in channels(name)]
        self._guard(lambda f: self._write(f, batches))

    def add_log_rows(self, rows: np.ndarray) -> None:
        """Rows of the run's :class:`~vilma.scenario.drive_log.DriveLog` (``t`` [s] gives the stamp)."""
        if len(rows):
            stamps = np.round(rows[:, 0] * 1e9).astype(np.int64)
            self._guard(lambda f: self._write(f, [(DRIVE_LOG, stamps, rows)]))

    def _write(self, f: McapFile, batches: list[tuple[str, np.ndarray, np.ndarray]]) -> None:
        for k, (name, st, v) in enumerate(batches, 1):  # a topic's messages in stamp order, one topic after another
            cid, lay = self._channel(f, name), self._layouts[name]
            f.write_records(cid, np.asarray(st, np.int64), lay.record_size,
                            lambda out, lay=lay, st=st, v=v, cid=cid: lay.records(st, v, cid, out),
                            close_chunk=k == len(batches))  # a file cut short holds whole batches

    def add_message(self, name: str, msg: Message) -> None:
        """One message of topic ``name`` (``pose``, ``cmd``, ``driver/status``, ``camera/front``, ``laser``...), as
        it went on the bus."""
        if name not in TOPICS:
            self._add_world(name, msg)
            return

        def put(f: McapFile) -> None:
            if name in SENSOR_TOPICS:
                values = msgspec_row(msg)
                written = channels(name)
                for k, c in enumerate(written, 1):  # a message and those beside it in the same chunk
                    f.write(self._channel(f, c), msg.stamp_ns, self._layouts[c].encode_one(msg.stamp_ns, values),
                            close_chunk=k == len(written))
            else:
                written = json_messages(name, msg)
                for k, (c, data) in enumerate(written, 1):  # a message and the scene drawn from it in one chunk
                    f.write(self._channel(f, c), msg.stamp_ns, data, close_chunk=k == len(written))
        self._guard(put)

    def _add_world(self, name: str, msg: Message) -> None:
        if self._file is None:
            return
        lay = self._world.get(name)
        if lay is None:
            check_world_topics((name,))
            lay = self._world[name] = world_channels(name, self._sensors.get(name), self.jpeg_quality)
            self._world_types.update(lay.topics)
        try:
            payloads = lay.encode(msg)  # outside the lock: JPEG takes milliseconds
        except WorldMessageError as e:
            note_dropped(self.dropped, "recording", name, e)
            return

        def put(f: McapFile) -> None:
            for k, ((c, _), data) in enumerate(zip(lay.topics, payloads, strict=True), 1):  # in one chunk
                f.write(self._channel(f, c), msg.stamp_ns, data, close_chunk=k == len(payloads))
        self._guard(put)

    def add_scenes(self, name: str, updates: list[tuple[int, bytes]]) -> None:
        """Scene updates (stamp [ns], JSON :mod:`vilma.record.road_scene`) of the topic ``name`` (``road``,
        ``traffic``)."""
        def put(f: McapFile) -> None:
            for k, (stamp, data) in enumerate(updates, 1):
                f.write(self._channel(f, name), stamp, data, close_chunk=k == len(updates))
        self._guard(put)

    def tick(self) -> None:
        """Flush the open chunk if it is a second old (call it now and then)."""
        self._guard(lambda f: f.tick())

    def add_attachment(self, name: str, media_type: str, data: bytes) -> None:
        """A file kept in the recording (the scenario, the scorecard)."""
        self._guard(lambda f: f.add_attachment(name, media_type, data))

    def add_metadata(self, name: str, data: dict) -> None:
        """A metadata record; values are written as JSON text."""
        self._guard(lambda f: f.add_metadata(name, {k: json.dumps(v) for k, v in data.items()}))

    @property
    def message_count(self) -> int:
        """Messages recorded so far."""
        return self._file.message_count if self._file is not None else 0

    def close(self) -> None:
        """Finish the file (summary and footer); closing again does nothing."""
        self._guard(lambda f: f.close())
        self._file = None


def json_messages(name: str, msg: Message) -> list[tuple[str, bytes]]:
    """The JSON messages (topic, payload) written from ``msg`` of topic ``name``: itself, and the scene drawn from
    it (:mod:`vilma.record.plan_scene`)."""
    return [(c, encode_struct(msg) if c == name else scene_json(c, msg)) for c in channels(name)]


def msgspec_row(msg: Message) -> list[float]:
    """A numeric message's fields after ``stamp_ns``, in order."""
    return [getattr(msg, f) for f in msg.__struct_fields__[1:]]


class BusRecorder(Closeable):
    """Records every topic of ``car`` on ``bus`` into ``recorder`` until :meth:`close`, and the world sensors'
    ``world_topics`` (e.g. ``("camera/front_left", "camera/front_left/depth", "laser")``); with a ``road``
    (:class:`~vilma.world.road_view.RoadView`), its road at the start and its traffic frames as the sim time of
    ``sim/status`` goes (:mod:`vilma.record.road_scene`).

    Raises:
        ValueError: a world topic that is not a camera or laser topic.
    """

    def __init__(self, bus: Bus, recorder: Recorder, car: str = "vilma", world_topics: tuple[str, ...] = (),
                 road: RoadView | None = None) -> None:
        self.recorder = recorder
        self._traffic = TrafficFrames(road) if road is not None else None
        if road is not None:
            recorder.add_scenes(ROAD, [(0, road_scene(road))])
        names = (*LIVE_TOPICS, *check_world_topics(world_topics))
        self._subs = [bus.subscribe(topic(name, car), self._taker(name)) for name in names]

    def _taker(self, name: str) -> Callable[[Message], None]:
        rec = self.recorder

        def take(msg: Message) -> None:
            rec.add_message(name, msg)
            if name == "sim/status" and self._traffic is not None:
                frames = self._traffic.until(msg.stamp_ns * 1e-9)
                if frames:
                    rec.add_scenes(TRAFFIC, frames)
        return take

    def close(self) -> None:
        """Stop listening and finish the file; closing again does nothing."""
        for s in self._subs:
            s.close()
        self.recorder.close()
