"""Topic names under a vehicle namespace and the message type each carries.

``vilma/<car>/<name>``, for example ``vilma/vilma/pose``. Sensor topics carry
what the simulator's sensors of the same name measure; ``cmd`` the actuator
commands; ``driver/status`` and ``driver/cmd`` the self-driver's state and
orders; ``sim/status`` and ``sim/cmd`` the simulator's.
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
}
"""Every topic of a car -> the message type it carries (requests on ``*/cmd`` are answered with a Reply)."""

DEFAULT_CAR = "vilma"


def topic(name: str, car: str = DEFAULT_CAR) -> str:
    """The full key of topic ``name`` of ``car``: ``vilma/<car>/<name>``."""
    if name not in TOPICS:
        raise ValueError(f"unknown topic {name!r}; known: {', '.join(TOPICS)}")
    if not car or "/" in car or "*" in car:
        raise ValueError(f"car name {car!r} must be a non-empty word without '/' or '*'")
    return f"vilma/{car}/{name}"


def message_type(key: str) -> type[m.Message]:
    """The message type a full key carries (``vilma/<car>/<name>``)."""
    parts = key.split("/", 2)
    if len(parts) != 3 or parts[0] != "vilma" or parts[2] not in TOPICS:
        raise ValueError(f"{key!r} is not a vilma topic (vilma/<car>/<name>)")
    return TOPICS[parts[2]]
