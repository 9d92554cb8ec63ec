"""Synthetic world-sensor messages with known content: a red square on grey, a depth ramp, a laser facing a wall."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from vilma.core.messages import Image, PointCloud
from vilma.plant3d.camera import CameraParams
from vilma.plant3d.laser import LaserParams

GREY = 64
"""Background level of :func:`red_square` images."""
SQUARE = (64, 40, 48, 32)
"""The red square of :func:`red_square`: first column, first row, width, height [px]."""
WALL = 5.0
"""Distance of the wall ahead in :func:`wall_scan` [m]."""


def red_square_pixels(width: int = 160, height: int = 120, square: tuple[int, int, int, int] = SQUARE) -> np.ndarray:
    """(height, width, 3) uint8: grey, with a pure red square at ``square``."""
    a = np.full((height, width, 3), GREY, np.uint8)
    x, y, w, h = square
    a[y:y + h, x:x + w] = (255, 0, 0)
    return a


def red_square(stamp_ns: int = 100_000_000, width: int = 160, height: int = 120, pad: int = 0,
               square: tuple[int, int, int, int] = SQUARE, frame_id: str = "front_left") -> Image:
    """An ``rgb8`` image of :func:`red_square_pixels`, each row padded with ``pad`` bytes (step = 3 width + pad)."""
    rows = red_square_pixels(width, height, square).reshape(height, 3 * width)
    data = np.hstack([rows, np.full((height, pad), 7, np.uint8)]).tobytes()
    return Image(stamp_ns, frame_id, width, height, "rgb8", 3 * width + pad, data)


def depth_ramp(width: int = 64, height: int = 48) -> np.ndarray:
    """(height, width) float32 depths [m]: inf in the top quarter (sky), then 2 m + 0.25 m a row down to the rest."""
    d = np.empty((height, width), "<f4")
    d[:height // 4] = np.inf
    d[height // 4:] = (2.0 + 0.25 * np.arange(height - height // 4, dtype=np.float32))[::-1, None]
    return d


def depth_image(stamp_ns: int = 100_000_000, width: int = 64, height: int = 48) -> Image:
    """A ``32FC1`` image of :func:`depth_ramp`."""
    return Image(stamp_ns, "front_left", width, height, "32FC1", 4 * width, depth_ramp(width, height).tobytes())


def wall_rays(n: int = 181, fov: float = math.pi) -> tuple[np.ndarray, np.ndarray]:
    """Ray angles [rad] from -fov/2 to +fov/2 (counter-clockwise) and their ranges [m] to a wall :data:`WALL` m
    ahead, hit by the rays within 40 deg of the axis (the others: inf)."""
    angles = np.linspace(-fov / 2, fov / 2, n)
    ranges = np.where(np.abs(angles) < math.radians(40), WALL / np.cos(angles), np.inf).astype("<f4")
    return angles, ranges


def wall_scan(stamp_ns: int = 100_000_000, n: int = 181) -> PointCloud:
    """A laser scan of :func:`wall_rays`: the hits at ``(WALL, WALL tan(a), 0)``."""
    angles, ranges = wall_rays(n)
    hit = np.isfinite(ranges)
    r = ranges[hit].astype(float)
    points = np.column_stack([r * np.cos(angles[hit]), r * np.sin(angles[hit]), np.zeros(len(r))]).astype("<f4")
    return PointCloud(stamp_ns, "laser", points.tobytes(), ranges.tobytes())


LAYERED = LaserParams(fov=90.0, resolution=15.0, layers=(-10.0, 0.0, 10.0))
"""A laser of three layers of seven rays each: 21 rays a scan."""


def layered_scan(stamp_ns: int = 100_000_000, laser: LaserParams = LAYERED) -> PointCloud:
    """A scan of ``laser`` facing a wall :data:`WALL` m ahead, hit by the rays within 40 deg of the axis in every
    layer but the last (which sees nothing): ranges along :meth:`~LaserParams.directions` (inf: no hit), the hits
    as the 3D plant makes them (float32 of the ray times the float32 range), in scan order."""
    rays = laser.directions()
    bearing = np.tile(laser.bearings, len(laser.layers))
    last = np.repeat(np.arange(len(laser.layers)) == len(laser.layers) - 1, len(laser.bearings))
    seen = (np.abs(bearing) < math.radians(40)) & ~last
    ranges = np.where(seen, WALL / np.where(seen, rays[:, 0], 1.0), np.inf).astype("<f4")
    hit = np.isfinite(ranges)
    points = (rays[hit] * ranges[hit, None]).astype("<f4")
    return PointCloud(stamp_ns, laser.name, points.tobytes(), ranges.tobytes())


FOXGLOVE_FILE = Path(__file__).parent / "data" / "foxglove_world.mcap"
"""Two captures a world topic in Foxglove's JSON schemas, as vilma wrote them before the ROS 2 types (see
data/README.md)."""
WORLD_TOPICS = ("camera/front_left", "camera/front_left/depth", "laser")
WORLD_SENSORS = (CameraParams(name="front_left", width=160, height=120, depth=True), LaserParams())
"""The sensors making :data:`WORLD_TOPICS`' messages: the laser's defaults are :func:`wall_rays`' 181 rays over
180 deg."""
PERIOD_NS = 100_000_000
"""The world sensors' period in :func:`write_world_recording` (10 Hz)."""


def world_at(stamp_ns: int) -> list[tuple[str, Image | PointCloud]]:
    """One capture of each of :data:`WORLD_TOPICS` at ``stamp_ns``."""
    return [("camera/front_left", red_square(stamp_ns)), ("camera/front_left/depth", depth_image(stamp_ns, 160, 120)),
            ("laser", wall_scan(stamp_ns))]


def write_world_recording(path, n: int = 5, **recorder) -> list[tuple[str, Image | PointCloud]]:
    """A recording at ``path``: poses, velocities and actuator states at 50 Hz driving along x at 1 m/s for ``n``
    world periods, and ``n`` captures of each world topic; returns the captures in the order recorded."""
    from vilma.core.messages import ActuatorState, Pose, Velocity
    from vilma.record.recorder import Recorder
    from vilma.sensors import Readings

    stamps = np.arange(1, 5 * n + 1, dtype=np.int64) * (PERIOD_NS // 5)
    values = np.zeros((len(stamps), 6))
    values[:, 0] = stamps * 1e-9
    velocity = np.zeros((len(stamps), 9))
    velocity[:, [0, 3]] = 1.0  # vx, vx_world
    rec = Recorder(path, **{"world_sensors": WORLD_SENSORS, **recorder})
    rec.add_readings({"pose": Readings("pose", Pose, stamps, values),
                      "velocity": Readings("velocity", Velocity, stamps, velocity),
                      "actuators": Readings("actuators", ActuatorState, stamps, np.zeros((len(stamps), 3)))})
    sent = [c for k in range(1, n + 1) for c in world_at(k * PERIOD_NS)]
    for name, msg in sent:
        rec.add_message(name, msg)
    rec.close()
    return sent


def write_layered_recording(path, n: int = 3) -> list[PointCloud]:
    """A recording at ``path`` of ``n`` :func:`layered_scan` of :data:`LAYERED` a :data:`PERIOD_NS`; returns them."""
    from vilma.record.recorder import Recorder

    sent = [layered_scan(k * PERIOD_NS) for k in range(1, n + 1)]
    with Recorder(path, world_sensors=(LAYERED,)) as rec:
        for scan in sent:
            rec.add_message("laser", scan)
    return sent


def write_old_layered_recording(path, n: int = 2) -> list[PointCloud]:
    """A recording at ``path`` as vilma wrote a multi-layer laser before its organized point clouds: ``n``
    :func:`layered_scan` of :data:`LAYERED` as a LaserScan of all layers' ranges one after another (one layer's
    angles) and the hits on ``laser/points``, serialised by ``rosbags`` and written by the ``mcap`` library."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    from vilma.record.world_cdr import LASER_SCAN, POINT_CLOUD2, SCHEMAS

    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    sent = [layered_scan(k * PERIOD_NS) for k in range(1, n + 1)]
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="tests")
        w.add_metadata("vilma", {"car": "vilma"})
        channels = {}
        for topic, kind in (("laser", LASER_SCAN), ("laser/points", POINT_CLOUD2)):
            sid = w.register_schema(kind, "ros2msg", SCHEMAS[kind])
            channels[topic] = w.register_channel(f"vilma/vilma/{topic}", "cdr", sid)
        b = LAYERED.bearings
        for c in sent:
            sec, nanosec = divmod(c.stamp_ns, 10**9)
            header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
                                              frame_id=c.frame_id)
            scan = t[LASER_SCAN](header=header, angle_min=b[0], angle_max=b[-1],
                                 angle_increment=math.radians(LAYERED.resolution), time_increment=0.0,
                                 scan_time=1 / LAYERED.rate_hz, range_min=LAYERED.min_range,
                                 range_max=LAYERED.max_range, ranges=np.frombuffer(c.ranges, "<f4"),
                                 intensities=np.zeros(0, np.float32))
            field = t["sensor_msgs/msg/PointField"]
            hits = len(c.points) // 12
            cloud = t[POINT_CLOUD2](header=header, height=1, width=hits, fields=[
                field(name=k, offset=4 * j, datatype=field.FLOAT32, count=1) for j, k in enumerate("xyz")],
                is_bigendian=False, point_step=12, row_step=12 * hits, data=np.frombuffer(c.points, np.uint8),
                is_dense=True)
            for topic, msg, kind in (("laser", scan, LASER_SCAN), ("laser/points", cloud, POINT_CLOUD2)):
                w.add_message(channels[topic], c.stamp_ns, bytes(store.serialize_cdr(msg, kind)), c.stamp_ns)
        w.finish()
    return sent
