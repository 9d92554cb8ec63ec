"""``vilma export rosbag2 RUN.mcap OUTDIR``: a recording as a ROS 2 bag (MCAP storage) of standard types.

Written with ``rosbags`` (no ROS install needed). Topics, as the original VILMA's where it had them:

=============== ================================ =====================================================
topic           type                             content
=============== ================================ =====================================================
``/pose``       geometry_msgs/msg/PoseStamped    frame ``map``; quaternion from roll, pitch, yaw
``/velocity``   geometry_msgs/msg/TwistStamped   linear: **world-frame** velocity [m/s] (as the
                                                 original's MORSE sensor); angular: body rates [rad/s]
``/gps``        sensor_msgs/msg/NavSatFix        latitude, longitude [deg], altitude [m]
``/imu``        sensor_msgs/msg/Imu              orientation, angular velocity, specific force
``/wheelspeed`` std_msgs/msg/Float64MultiArray   ``[fl, fr, rl, rr]`` [rad/s]
``/odom``       nav_msgs/msg/Odometry            frame ``odom``, child ``<car>``; x, y, yaw; speed
                                                 and yaw rate in the twist
``/actuators``  std_msgs/msg/Float64MultiArray   ``[steer rad, drive_force N, brake_force N]``
``/cmd``        std_msgs/msg/Float64MultiArray   ``[steer rad, drive, brake, velocity_limit m/s,
                                                 autonomous 0/1]``; the layout's label names the
                                                 longitudinal mode (``drive[force|accel|power]``)
``/tf``         tf2_msgs/msg/TFMessage           ``map`` -> ``<car>`` from the pose
``/tf_static``  tf2_msgs/msg/TFMessage           ``<car>`` -> each world sensor's frame, its mount
                                                 (:mod:`vilma.record.sensor_frames`): one message,
                                                 stamp 0, offered QoS :data:`LATCHED` (durability
                                                 transient local, as ``ros2 bag`` records it)
``/drive_log``  std_msgs/msg/Float64MultiArray   the runner's row (labels: the DriveLog columns)
``/objects``    visualization_msgs/msg/          the objects sensor's list, frame ``map``: a
                MarkerArray                      ``DELETEALL``, then an object a ``CUBE`` (ns
                                                 ``objects``, its id, on the ground at its reference
                                                 point, scale its length, width and
                                                 :data:`OBJECT_HEIGHT`)
                                                 and an ``ARROW`` (ns ``objects/velocity``, its id,
                                                 along its yaw, ``scale.x`` its speed [m/s]: a second
                                                 of travel)
=============== ================================ =====================================================

ROS 2 has no standard message for true objects with id, pose, speed and size: a MarkerArray carries them all
(the speed as its arrow's length) and RViz and Foxglove draw it as it is, where a ``std_msgs/String`` of the
JSON would be readable by vilma alone.

and the world sensors' topics, under ROS ``image_transport`` names, as recorded
(:mod:`vilma.record.world_cdr`; the CDR payloads are copied as they are):

================================== =============================== ==========================================
``/camera/<name>/compressed``      sensor_msgs/msg/CompressedImage a JPEG-recorded colour image
``/camera/<name>``                 sensor_msgs/msg/Image           a raw-recorded colour image (``rgb8``)
``/camera/<name>/camera_info``     sensor_msgs/msg/CameraInfo      the camera's intrinsics
``/camera/<name>/depth``           sensor_msgs/msg/Image           depth ``32FC1`` [m], little-endian
``/laser``                         sensor_msgs/msg/LaserScan       a laser of one layer: the ranges a ray
``/laser/points``                  sensor_msgs/msg/PointCloud2     beside it, the hits: one row of ``x, y, z``
                                                                   float32 [m]
``/laser``                         sensor_msgs/msg/PointCloud2     a laser of several layers, organized: a
                                                                   row a layer (``x, y, z``, NaN: no hit;
                                                                   ``range``, inf: no hit; ``ring``), alone
================================== =============================== ==========================================

A recording made before these types (Foxglove's JSON schemas) gives the same topics but camera info and
LaserScan, which it lacks: its laser's hits go to ``/laser`` as a PointCloud2 (stride 12, the laser's frame),
its JPEGs as recorded (no second compression).

Each message's bag timestamp and header stamp are its sim time.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from vilma.core import messages as m
from vilma.core.geometry import quaternion_from_euler
from vilma.record.reader import Recording, RecordingError, read_recording
from vilma.record.schemas import FRAME_TRANSFORM, TF_STATIC
from vilma.record.sensor_frames import SensorFrame, decode_frame
from vilma.record.world_cdr import COMPRESSED_IMAGE as ROS_COMPRESSED_IMAGE
from vilma.record.world_cdr import SCHEMAS
from vilma.record.world_schemas import COMPRESSED_IMAGE, compressed_image
from vilma.scenario.drive_log import COLUMNS

STORE = Stores.ROS2_HUMBLE
"""The message definitions written (ROS 2 Humble's)."""
OBJECT_HEIGHT = 1.5
"""Height of an object's cube [m] (the objects sensor gives a footprint)."""
_NEVER = QosTime(2147483647, 4294967295)  # rmw's infinite duration
LATCHED = (Qos(QosHistory.UNKNOWN, 0, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL, _NEVER, _NEVER,
               QosLiveliness.AUTOMATIC, _NEVER, avoid_ros_namespace_conventions=False),)
"""The offered QoS of ``/tf_static``: reliable, transient local (a late subscriber gets the message), as ``ros2 bag``
records tf2's static broadcaster's (history and depth are not seen in discovery: unknown, 0)."""


class _Types:
    def __init__(self) -> None:
        self.store = get_typestore(STORE)
        t = self.store.types
        self.Time, self.Header = t["builtin_interfaces/msg/Time"], t["std_msgs/msg/Header"]
        self.Point, self.Quat, self.Vec = t["geometry_msgs/msg/Point"], t["geometry_msgs/msg/Quaternion"], \
            t["geometry_msgs/msg/Vector3"]
        self.t = t

    def header(self, stamp_ns: int, frame: str):
        return self.Header(stamp=self.Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000),
                           frame_id=frame)

    def quat(self, roll: float, pitch: float, yaw: float):
        x, y, z, w = (float(q) for q in quaternion_from_euler(roll, pitch, yaw))
        return self.Quat(x=x, y=y, z=z, w=w)

    def array(self, values, labels: str):
        t = self.t
        dim = t["std_msgs/msg/MultiArrayDimension"](label=labels, size=len(values), stride=len(values))
        return t["std_msgs/msg/Float64MultiArray"](layout=t["std_msgs/msg/MultiArrayLayout"](dim=[dim], data_offset=0),
                                                   data=np.asarray(values, dtype=np.float64))


def _pose(T: _Types, p: m.Pose, car: str):
    t = T.t
    return t["geometry_msgs/msg/PoseStamped"](header=T.header(p.stamp_ns, "map"), pose=t["geometry_msgs/msg/Pose"](
        position=T.Point(x=p.x, y=p.y, z=p.z), orientation=T.quat(p.roll, p.pitch, p.yaw)))


def _velocity(T: _Types, v: m.Velocity, car: str):
    t = T.t
    return t["geometry_msgs/msg/TwistStamped"](header=T.header(v.stamp_ns, car), twist=t["geometry_msgs/msg/Twist"](
        linear=T.Vec(x=v.vx_world, y=v.vy_world, z=v.vz_world), angular=T.Vec(x=v.wx, y=v.wy, z=v.wz)))


def _gps(T: _Types, g: m.GpsFix, car: str):
    t = T.t
    status = t["sensor_msgs/msg/NavSatStatus"](status=0, service=1)
    return t["sensor_msgs/msg/NavSatFix"](header=T.header(g.stamp_ns, "gps"), status=status, latitude=g.latitude,
                                          longitude=g.longitude, altitude=g.altitude,
                                          position_covariance=np.zeros(9), position_covariance_type=0)


def _imu(T: _Types, i: m.Imu, car: str):
    return T.t["sensor_msgs/msg/Imu"](
        header=T.header(i.stamp_ns, car), orientation=T.Quat(x=i.qx, y=i.qy, z=i.qz, w=i.qw),
        orientation_covariance=np.zeros(9), angular_velocity=T.Vec(x=i.wx, y=i.wy, z=i.wz),
        angular_velocity_covariance=np.zeros(9), linear_acceleration=T.Vec(x=i.ax, y=i.ay, z=i.az),
        linear_acceleration_covariance=np.zeros(9))


def _odometry(T: _Types, o: m.Odometry, car: str):
    t = T.t
    pose = t["geometry_msgs/msg/PoseWithCovariance"](
        pose=t["geometry_msgs/msg/Pose"](position=T.Point(x=o.x, y=o.y, z=0.0), orientation=T.quat(0.0, 0.0, o.yaw)),
        covariance=np.zeros(36))
    twist = t["geometry_msgs/msg/TwistWithCovariance"](twist=t["geometry_msgs/msg/Twist"](
        linear=T.Vec(x=o.speed, y=0.0, z=0.0), angular=T.Vec(x=0.0, y=0.0, z=o.yaw_rate)), covariance=np.zeros(36))
    return t["nav_msgs/msg/Odometry"](header=T.header(o.stamp_ns, "odom"), child_frame_id=car, pose=pose, twist=twist)


def _wheels(T: _Types, w: m.WheelSpeeds, car: str):
    return T.array([w.fl, w.fr, w.rl, w.rr], "fl,fr,rl,rr [rad/s]")


def _actuators(T: _Types, a: m.ActuatorState, car: str):
    return T.array([a.steer, a.drive_force, a.brake_force], "steer [rad],drive_force [N],brake_force [N]")


def _cmd(T: _Types, c: m.ActuatorCommand, car: str):
    return T.array([c.steer, c.drive, c.brake, c.velocity_limit, float(c.autonomous)],
                   f"steer [rad],drive[{c.longitudinal.value}],brake,velocity_limit [m/s],autonomous")


def _objects(T: _Types, ol: m.ObjectList, car: str):
    header, Marker = T.header(ol.stamp_ns, "map"), T.t["visualization_msgs/msg/Marker"]
    markers = [_marker(T, header, "", 0, Marker.DELETEALL, Marker.CUBE, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)]
    for o in ol.objects:
        markers += [_marker(T, header, "objects", o.id, Marker.ADD, Marker.CUBE, o.x, o.y, o.yaw, o.length, o.width,
                            OBJECT_HEIGHT),
                    _marker(T, header, "objects/velocity", o.id, Marker.ADD, Marker.ARROW, o.x, o.y, o.yaw, o.speed,
                            0.2, 0.2)]
    return T.t["visualization_msgs/msg/MarkerArray"](markers=markers)


def _marker(T: _Types, header, ns: str, mid: int, action: int, kind: int, x: float, y: float, yaw: float,
            sx: float, sy: float, sz: float):
    """A marker ``kind`` at ``x, y`` [m] standing on the ground (its centre ``sz / 2`` up) facing ``yaw`` [rad], of
    scale ``sx, sy, sz``, in the traffic's orange (:mod:`vilma.record.road_scene`)."""
    t = T.t
    pose = t["geometry_msgs/msg/Pose"](position=T.Point(x=x, y=y, z=sz / 2), orientation=T.quat(0.0, 0.0, yaw))
    return t["visualization_msgs/msg/Marker"](
        header=header, ns=ns, id=mid, type=kind, action=action, pose=pose, scale=T.Vec(x=sx, y=sy, z=sz),
        color=t["std_msgs/msg/ColorRGBA"](r=1.0, g=0.55, b=0.1, a=0.9), lifetime=t["builtin_interfaces/msg/Duration"](
            sec=0, nanosec=0), frame_locked=False, points=[], colors=[], texture_resource="",
        texture=t["sensor_msgs/msg/CompressedImage"](header=header, format="", data=np.zeros(0, np.uint8)),
        uv_coordinates=[], text="", mesh_resource="", mesh_file=t["visualization_msgs/msg/MeshFile"](
            filename="", data=np.zeros(0, np.uint8)), mesh_use_embedded_materials=False)


def _tf(T: _Types, p: m.Pose, car: str):
    t = T.t
    tr = t["geometry_msgs/msg/Transform"](translation=T.Vec(x=p.x, y=p.y, z=p.z),
                                          rotation=T.quat(p.roll, p.pitch, p.yaw))
    ts = t["geometry_msgs/msg/TransformStamped"](header=T.header(p.stamp_ns, "map"), child_frame_id=car, transform=tr)
    return t["tf2_msgs/msg/TFMessage"](transforms=[ts])


def _tf_static(T: _Types, stamp_ns: int, frames: list[SensorFrame]):
    t = T.t
    return t["tf2_msgs/msg/TFMessage"](transforms=[t["geometry_msgs/msg/TransformStamped"](
        header=T.header(stamp_ns, f.parent), child_frame_id=f.child, transform=t["geometry_msgs/msg/Transform"](
            translation=T.Vec(x=f.translation[0], y=f.translation[1], z=f.translation[2]),
            rotation=T.Quat(x=f.rotation[0], y=f.rotation[1], z=f.rotation[2], w=f.rotation[3])))
        for f in frames])


def _sensor_frames(rec: Recording) -> tuple[int, list[SensorFrame]]:
    """The first stamp [ns] and the frames of the recording's ``tf_static`` (none: a recording made before it)."""
    if rec.schemas.get(TF_STATIC) != FRAME_TRANSFORM:
        return 0, []
    try:
        decoded = [decode_frame(p) for p in rec.payloads(TF_STATIC)]
    except ValueError as e:
        raise RecordingError(f"{rec.path}: topic {TF_STATIC}: {e}") from None
    return min((st for st, _ in decoded), default=0), [f for _, f in decoded]


def _image(T: _Types, i: m.Image):
    return T.t["sensor_msgs/msg/Image"](header=T.header(i.stamp_ns, i.frame_id), height=i.height, width=i.width,
                                        encoding=i.encoding, is_bigendian=0, step=i.step,
                                        data=np.frombuffer(i.data, np.uint8))


def _jpeg(T: _Types, payload: bytes):
    stamp_ns, frame_id, fmt, data = compressed_image(payload)  # the recorded JPEG as it is: no second compression
    return stamp_ns, T.t["sensor_msgs/msg/CompressedImage"](header=T.header(stamp_ns, frame_id), format=fmt,
                                                            data=np.frombuffer(data, np.uint8))


def _cloud(T: _Types, c: m.PointCloud):
    t = T.t
    field = t["sensor_msgs/msg/PointField"]
    n = len(c.points) // 12
    return t["sensor_msgs/msg/PointCloud2"](
        header=T.header(c.stamp_ns, c.frame_id), height=1, width=n,
        fields=[field(name=k, offset=4 * j, datatype=field.FLOAT32, count=1) for j, k in enumerate("xyz")],
        is_bigendian=False, point_step=12, row_step=12 * n, data=np.frombuffer(c.points, np.uint8), is_dense=True)


def _world(T: _Types, rec: Recording, name: str):
    """ROS topic, ROS type and the (stamp, message or its CDR) pairs of world topic ``name``."""
    schema = rec.schemas[name]
    if schema in SCHEMAS:  # recorded as ROS 2 messages already
        ros_topic = f"/{name}/compressed" if schema == ROS_COMPRESSED_IMAGE else f"/{name}"
        return ros_topic, schema, zip(*rec.raw[name], strict=True)
    if schema == COMPRESSED_IMAGE:
        return f"/{name}/compressed", "sensor_msgs/msg/CompressedImage", (_jpeg(T, p) for p in rec.payloads(name))
    if name == "laser":
        return "/laser", "sensor_msgs/msg/PointCloud2", ((c.stamp_ns, _cloud(T, c)) for c in rec.messages(name))
    return f"/{name}", "sensor_msgs/msg/Image", ((i.stamp_ns, _image(T, i)) for i in rec.messages(name))


TOPICS = {  # vilma topic -> (ROS topic, ROS type, converter)
    "pose": ("/pose", "geometry_msgs/msg/PoseStamped", _pose),
    "velocity": ("/velocity", "geometry_msgs/msg/TwistStamped", _velocity),
    "gps": ("/gps", "sensor_msgs/msg/NavSatFix", _gps),
    "imu": ("/imu", "sensor_msgs/msg/Imu", _imu),
    "wheel_speed": ("/wheelspeed", "std_msgs/msg/Float64MultiArray", _wheels),
    "odometry": ("/odom", "nav_msgs/msg/Odometry", _odometry),
    "actuators": ("/actuators", "std_msgs/msg/Float64MultiArray", _actuators),
    "cmd": ("/cmd", "std_msgs/msg/Float64MultiArray", _cmd),
    "objects": ("/objects", "visualization_msgs/msg/MarkerArray", _objects),
}
"""What :func:`export_rosbag2` writes for each vilma topic (see the module docstring)."""


def export_rosbag2(recording: Recording | Path, out_dir: Path) -> dict[str, int]:
    """Write the recording ``recording`` (a path, or one already read) as a rosbag2 in ``out_dir`` (which must not
    exist yet).

    Returns the number of messages written per ROS topic.

    Raises:
        FileExistsError: ``out_dir`` exists (rosbags will not write into it).
        RecordingError: the recording cannot be read.
    """
    rec = recording if isinstance(recording, Recording) else read_recording(recording)
    out_dir = Path(out_dir)
    if out_dir.exists():
        raise FileExistsError(f"{out_dir} exists; give a new folder for the bag")
    T = _Types()
    counts: dict[str, int] = {}
    with Writer(out_dir, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        def put(ros_topic: str, ros_type: str, items, qos: tuple[Qos, ...] = ()) -> None:
            conn = None
            for stamp, msg in items:
                if conn is None:
                    conn = w.add_connection(ros_topic, ros_type, typestore=T.store, offered_qos_profiles=qos)
                w.write(conn, stamp, msg if isinstance(msg, bytes) else T.store.serialize_cdr(msg, ros_type))
                counts[ros_topic] = counts.get(ros_topic, 0) + 1

        for name, (ros_topic, ros_type, convert) in TOPICS.items():
            if rec.count(name):
                put(ros_topic, ros_type, ((x.stamp_ns, convert(T, x, rec.car)) for x in rec.messages(name)))
        if rec.count("pose"):
            put("/tf", "tf2_msgs/msg/TFMessage",
                ((p.stamp_ns, _tf(T, p, rec.car)) for p in rec.messages("pose")))
        stamp, frames = _sensor_frames(rec)
        if frames:
            put("/tf_static", "tf2_msgs/msg/TFMessage", [(stamp, _tf_static(T, stamp, frames))], LATCHED)
        world = set(rec.world_topics)
        for name in rec.topics:
            if name in world or rec.schemas[name] in SCHEMAS:  # with those beside them (camera_info...)
                put(*_world(T, rec, name))
        rows = rec.drive_log()
        if len(rows):
            labels = ",".join(COLUMNS)
            put("/drive_log", "std_msgs/msg/Float64MultiArray",
                ((round(r[0] * 1e9), T.array(r, labels)) for r in rows if math.isfinite(r[0])))
    return counts
