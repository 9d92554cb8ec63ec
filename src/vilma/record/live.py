"""``--foxglove``: a Foxglove WebSocket server (foxglove-sdk) broadcasting a car's topics live, with sim time.

The channels and their messages are those of a recording (:mod:`vilma.record.schemas`): the
sensors in CDR as standard ROS 2 types where one fits (``geometry_msgs/msg/PoseStamped``,
``sensor_msgs/msg/Imu``, ``sensor_msgs/msg/NavSatFix``, ``nav_msgs/msg/Odometry``...) with the topics written
beside them (``vilma/<car>/tf`` as ``foxglove_msgs/msg/FrameTransform``...), orders and
statuses as JSON ``vilma.<Type>``; the world sensors'
topics it is given as :mod:`vilma.record.world_schemas` lays them out (colour images JPEG,
depth ``foxglove.RawImage``, the laser ``foxglove.PointCloud``), and, given the world sensors' parameters,
their mounts on ``vilma/<car>/tf_static`` (:mod:`vilma.record.sensor_frames`), sent again to each client that
subscribes to it (a latched topic: they never change, so they are never published otherwise). Each
message's log time is its sim time, and the server broadcasts the sim time of
each ``sim/status`` (Foxglove's clock follows the simulation). Open Foxglove,
"Open connection", ``ws://127.0.0.1:8765``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

from vilma.bus.base import Bus
from vilma.bus.topics import SENSOR_TOPICS, TOPICS, topic
from vilma.core.closing import Closeable
from vilma.core.extras import require
from vilma.core.messages import Message
from vilma.core.net import is_loopback
from vilma.record.plan_scene import PLANNING_SCENES
from vilma.record.recorder import LIVE_TOPICS, json_messages, msgspec_row
from vilma.record.road_scene import SCENE_SCHEMA, SCENE_TOPICS, SCENE_UPDATE, SceneFeed
from vilma.record.schemas import (
    COMPANIONS,
    FRAME_TRANSFORM,
    FRAME_TRANSFORM_SCHEMA,
    TF_STATIC,
    channels,
    numeric_layouts,
    struct_schema,
)
from vilma.record.sensor_frames import encode_frame, sensor_frames
from vilma.record.world_cdr import WorldSensorParams
from vilma.record.world_schemas import (
    JPEG_QUALITY,
    WorldMessageError,
    check_world_topics,
    note_dropped,
    world_layout,
)

if TYPE_CHECKING:
    from vilma.world.road_view import RoadView

log = logging.getLogger(__name__)

DEFAULT_PORT = 8765
"""Foxglove's usual WebSocket port."""


class FoxgloveLive(Closeable):
    """Serves car ``car``'s topics on ``bus`` to Foxglove at ``host``:``port`` (0: a free port) until :meth:`close`,
    and the world sensors' ``world_topics`` (colour images as JPEG of ``jpeg_quality``, None: raw); with a
    ``road`` (:class:`~vilma.world.road_view.RoadView`), its road and traffic as scene primitives
    (:mod:`vilma.record.road_scene`) on the sim time of ``sim/status``; with ``world_sensors`` (the cameras' and
    laser's parameters), their mounts on ``tf_static`` to each client that subscribes to it.

    Raises:
        ValueError: a world topic that is not a camera or laser topic, or a bad JPEG quality.
    """

    def __init__(self, bus: Bus, car: str = "vilma", host: str = "127.0.0.1", port: int = DEFAULT_PORT,
                 world_topics: tuple[str, ...] = (), jpeg_quality: int | None = JPEG_QUALITY,
                 road: RoadView | None = None, world_sensors: tuple[WorldSensorParams, ...] = ()) -> None:
        require("foxglove", "the live Foxglove view")
        import foxglove
        from foxglove.websocket import Capability

        self._world = {name: world_layout(name, jpeg_quality) for name in check_world_topics(world_topics)}
        self._frames = [encode_frame(f) for f in sensor_frames(world_sensors, car)]
        self._now = 0  # the latest sim time [ns]
        if not is_loopback(host):
            log.warning("Foxglove server on %s, beyond this machine: anyone who reaches it sees the car", host)
        self._fox = foxglove
        self.car = car
        self._context = foxglove.Context()
        self._layouts = numeric_layouts(car)
        self._channels: dict[str, object] = {}
        self.dropped: dict[str, int] = {}
        """Malformed world-sensor messages dropped, by topic."""
        self.server = foxglove.start_server(name=f"vilma ({car})", host=host, port=port, context=self._context,
                                            capabilities=[Capability.Time],
                                            server_listener=_latch(self._send_frames) if self._frames else None)
        for name in (*LIVE_TOPICS, *(c for cs in COMPANIONS.values() for c in cs), *self._world,
                     *((TF_STATIC,) if self._frames else ())):
            self._channel(name)  # advertised from the start: a client sees every channel at once
        self.show_road(road)
        self._subs = [bus.subscribe(topic(name, car), self._taker(name)) for name in (*LIVE_TOPICS, *self._world)]

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return self.server.port

    def show_road(self, road: RoadView | None) -> None:
        """Draw ``road`` (its road and traffic) from the next ``sim/status`` on; None: no road."""
        for name in SCENE_TOPICS if road is not None else ():
            self._channel(name)
        self._scene = SceneFeed(road) if road is not None else None

    def _channel(self, name: str):
        ch = self._channels.get(name)
        if ch is None:
            lay = self._layouts.get(name) or self._world.get(name)
            schema_name, schema = ((lay.schema_name, lay.schema) if lay is not None
                                   else (FRAME_TRANSFORM, FRAME_TRANSFORM_SCHEMA) if name == TF_STATIC
                                   else (SCENE_UPDATE, SCENE_SCHEMA) if name in SCENE_TOPICS or name in PLANNING_SCENES
                                   else (f"vilma.{TOPICS[name].__name__}", struct_schema(TOPICS[name])))
            cdr = name in self._layouts or name == TF_STATIC
            ch = self._fox.Channel(f"vilma/{self.car}/{name}", message_encoding="cdr" if cdr else "json",
                                   context=self._context, schema=self._fox.Schema(
                                       name=schema_name, encoding="ros2msg" if cdr else "jsonschema", data=schema))
            self._channels[name] = ch
        return ch

    def _taker(self, name: str) -> Callable[[Message], None]:
        world = self._world.get(name)
        if world is not None:
            def take_world(msg: Message) -> None:
                ch = self._channel(name)
                if not ch.has_sinks():  # nobody watches: spare the JPEG
                    return
                try:
                    data = world.encode(msg)
                except WorldMessageError as e:
                    note_dropped(self.dropped, "Foxglove", name, e)
                    return
                ch.log(data, log_time=msg.stamp_ns)
            return take_world

        def take(msg: Message) -> None:
            if name in SENSOR_TOPICS:
                values = msgspec_row(msg)
                for c in channels(name):
                    self._channel(c).log(self._layouts[c].encode_one(msg.stamp_ns, values), log_time=msg.stamp_ns)
            else:
                for c, data in json_messages(name, msg):
                    self._channel(c).log(data, log_time=msg.stamp_ns)
                if name == "sim/status":
                    self._now = msg.stamp_ns
                    self.server.broadcast_time(msg.stamp_ns)
                    if self._scene is not None:
                        for scene, data in self._scene.due(msg.stamp_ns):
                            self._channel(scene).log(data, log_time=msg.stamp_ns)
        return take

    def _send_frames(self, topic_name: str) -> None:
        """The sensors' mounts (stamped 0, logged at the latest sim time), if ``topic_name`` is ``tf_static``'s:
        a client has just subscribed to it (the others subscribed get them again, which changes nothing)."""
        if topic_name == f"vilma/{self.car}/{TF_STATIC}":
            ch = self._channel(TF_STATIC)
            for data in self._frames:
                ch.log(data, log_time=self._now)

    def close(self) -> None:
        """Stop listening to the bus and stop the server; closing again does nothing."""
        for s in self._subs:
            s.close()
        self.server.stop()


def _latch(on_subscribe: Callable[[str], None]):
    """A foxglove-sdk server listener calling ``on_subscribe`` with the topic each time a client subscribes to a
    channel (after the subscription holds: what it logs then reaches that client)."""
    from foxglove.websocket import ServerListener

    class Latch(ServerListener):
        def on_subscribe(self, client, channel) -> None:
            on_subscribe(channel.topic)
    return Latch()
