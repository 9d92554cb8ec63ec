"""Topic names under a vehicle namespace and the message type each carries.

``vilma/<car>/<name>``, for example ``vilma/vilma/pose``. Sensor topics carry
what the simulator's sensors of the same name measure; ``cmd`` the actuator
commands; ``driver/status`` and ``driver/cmd`` the self-driver's state and
orders; ``sim/status`` and ``sim/cmd`` the simulator's; ``objects`` the objects
sensor's lists (of varying length, so not a sensor topic); ``perception/objects`` the
objects a planned car perceives and ``planning/plan`` its planning cycles. The 3D plant's world
sensors add ``camera/<name>`` (and ``camera/<name>/depth``) images and the
``laser`` point cloud.
"""

from __future__ import annotations

from vilma.core import messages as m

SENSOR_TOPICS: dict[str, type[m.Message]] = {
    "pose": m.Pose,
    "velocity": m.Velocity,
    "gps": m.GpsFix,
    "imu": m.Imu,
    "wheel_speed": m.WheelSpeeds,
    "odometry": m.Odometry,
    "actuators": m.ActuatorState,
}
"""Sensor name (as the simulator's) -> message type."""

TOPICS: dict[str, type[m.Message]] = {
    **SENSOR_TOPICS,
    "cmd": m.ActuatorCommand,
    "driver/status": m.DriverStatus,
    "driver/cmd": m.DriverOrder,
    "sim/status": m.SimStatus,
    "sim/cmd": m.SimControl,
    "objects": m.ObjectList,
    "perception/objects": m.TrackList,
    "planning/plan": m.LocalPlan,
}
"""Every topic of a car -> the message type it carries (requests on ``*/cmd`` are answered with a Reply)."""
WORLD_TOPICS: dict[str, type[m.Message]] = {"camera": m.Image, "laser": m.PointCloud}
"""World sensors of the 3D plant: ``laser``, and ``camera/<name>`` or ``camera/<name>/depth`` for each camera."""

DEFAULT_CAR = "vilma"


def _type_of(name: str) -> type[m.Message] | None:
    if name in TOPICS:
        return TOPICS[name]
    if name == "laser":
        return WORLD_TOPICS["laser"]
    parts = name.split("/")
    if parts[0] == "camera" and len(parts) in (2, 3) and parts[1] and parts[1] != "*" and parts[2:] in ([], ["depth"]):
        return WORLD_TOPICS["camera"]
    return None


def topic(name: str, car: str = DEFAULT_CAR) -> str:
    """The full key of topic ``name`` of ``car``: ``vilma/<car>/<name>``."""
    if _type_of(name) is None:
        raise ValueError(f"unknown topic {name!r}; known: {', '.join(TOPICS)}, laser, camera/<name>[/depth]")
    if not car or "/" in car or "*" in car:
        raise ValueError(f"car name {car!r} must be a non-empty word without '/' or '*'")
    return f"vilma/{car}/{name}"


def message_type(key: str) -> type[m.Message]:
    """The message type a full key carries (``vilma/<car>/<name>``)."""
    parts = key.split("/", 2)
    kind = _type_of(parts[2]) if len(parts) == 3 and parts[0] == "vilma" else None
    if kind is None:
        raise ValueError(f"{key!r} is not a vilma topic (vilma/<car>/<name>)")
    return kind
