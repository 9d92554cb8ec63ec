"""The world sensors' frames on the car: each mount as a static transform ``<car>`` -> ``<sensor>``.

A recording holds them on ``tf_static`` (``foxglove_msgs/msg/FrameTransform``, one message a sensor, stamp 0),
a ROS 2 bag on ``/tf_static`` (:mod:`vilma.record.rosbag`), so that Foxglove and RViz place the scans and images,
whose ``frame_id`` is the sensor's name, on the car. The car's frame is at its centre of mass, x forward, y left,
z up (``tf`` places it in the map).

- A laser's frame is its mount turned by its yaw about z: x along the scan's centre, y left, z up
  (:meth:`~vilma.plant3d.laser.LaserParams.directions`; the hit points are in it).
- A camera's frame is the ROS optical frame its images are in: z along the optical axis, x right, y down (the
  image's first row is its top, its first column its left: :meth:`~vilma.plant3d.camera.CameraSensor.capture`).
  Its rotation is Rz(yaw) Ry(pitch) :data:`OPTICAL`: the body frame turned by the yaw, then by the pitch about
  the new y (a positive pitch turns x toward -z: the camera looks down), then the optical rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

from vilma.core.geometry import quaternion_from_euler
from vilma.plant3d.camera import CameraParams
from vilma.plant3d.laser import LaserParams
from vilma.record.cdr import CdrBody, CdrReader

OPTICAL = (-0.5, 0.5, -0.5, 0.5)
"""Quaternion (x, y, z, w) of a camera's optical frame in its body-aligned one (z forward, x right, y down in x
forward, y left, z up): roll -pi/2, pitch 0, yaw -pi/2, as ROS's camera drivers (REP 103)."""


@dataclass(frozen=True, slots=True)
class SensorFrame:
    """A frame fixed to its parent: where its origin is and how its axes are turned."""

    parent: str
    """Parent frame (the car's)."""
    child: str
    """The sensor's frame (its name)."""
    translation: tuple[float, float, float]
    """Origin in the parent frame [m]."""
    rotation: tuple[float, float, float, float]
    """Quaternion (x, y, z, w) turning the parent's axes into the child's (a vector in the child frame times it
    is the vector in the parent frame)."""


def quaternion_product(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    """Hamilton product ``a b`` of quaternions (x, y, z, w): the rotation ``b``, then ``a`` (in the frame before)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz)


def sensor_frame(sensor: CameraParams | LaserParams, car: str) -> SensorFrame:
    """The frame of ``sensor`` on car ``car`` (see the module docstring)."""
    if isinstance(sensor, LaserParams):
        rotation = tuple(float(q) for q in quaternion_from_euler(0.0, 0.0, sensor.yaw))
    else:
        mount = tuple(float(q) for q in quaternion_from_euler(0.0, sensor.pitch, sensor.yaw))
        rotation = quaternion_product(mount, OPTICAL)
    return SensorFrame(car, sensor.name, tuple(float(v) for v in sensor.position), rotation)


def sensor_frames(sensors: tuple[CameraParams | LaserParams, ...], car: str) -> tuple[SensorFrame, ...]:
    """The frames of ``sensors`` on car ``car``, but of one named as the car (the car's frame is placed by ``tf``:
    a transform to itself would make a loop)."""
    return tuple(sensor_frame(s, car) for s in sensors if s.name != car)


def encode_frame(frame: SensorFrame, stamp_ns: int = 0) -> bytes:
    """The ``foxglove_msgs/msg/FrameTransform`` CDR payload of ``frame`` at ``stamp_ns`` [ns]."""
    return (CdrBody().time(stamp_ns).string(frame.parent).string(frame.child)
            .number("d", *frame.translation, *frame.rotation)).payload()[0]


def decode_frame(payload: bytes) -> tuple[int, SensorFrame]:
    """The stamp [ns] and frame of a payload :func:`encode_frame` wrote.

    Raises:
        ValueError: a payload that does not decode (one line).
    """
    try:
        r = CdrReader(payload)
        stamp_ns, parent, child = r.time(), r.string(), r.string()
        v = r.number("d", 7)
    except (ValueError, IndexError) as e:  # a bad string's UTF-8 too
        raise ValueError(f"a FrameTransform message does not decode: {e}") from None
    return stamp_ns, SensorFrame(parent, child, v[:3], v[3:])
