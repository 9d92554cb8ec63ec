"""The plant state: named indices into one float vector, and a typed view.

Layout of the plant vector ``z`` (float64, length :data:`NZ`)::

    X, Y       position of the centre of mass, ENU world [m]
    YAW        heading, counter-clockwise from +x [rad] (not wrapped while integrating)
    VX, VY     velocity of the centre of mass in the body frame [m/s]
    YAW_RATE   [rad/s]
    STEER      front-wheel angle applied [rad], positive left
    DRIVE      drive force applied at the wheels [N]
    BRAKE      brake force applied [N], >= 0

The first :data:`NX` entries are the vehicle state ``x``; the rest, ``u``,
are the actuators' outputs, held constant over one physics step.

The 3D plant also records, beside ``z``, what only it has (float64, length :data:`N3`)::

    HEIGHT       height of the centre of mass above its rest height on flat ground [m]
    ROLL, PITCH  ZYX Euler angles of the body [rad] (roll about body x, pitch positive nose down)
    VZ           vertical velocity, world [m/s]
    WX, WY, WZ   angular velocity, body frame [rad/s]
    FX, FY, FZ   specific force at the IMU, body frame [m/s^2] (+g upward at rest)
"""

from __future__ import annotations

from dataclasses import astuple, dataclass

import numpy as np

from vilma.core.geometry import wrap_angle

X, Y, YAW, VX, VY, YAW_RATE = 0, 1, 2, 3, 4, 5
STEER, DRIVE, BRAKE = 6, 7, 8
NX = 6
NZ = 9
HEIGHT, ROLL, PITCH, VZ, WX, WY, WZ, FX, FY, FZ = range(10)
N3 = 10


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleState:
    """A snapshot of the plant (units as in the module docstring)."""

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    vx: float = 0.0
    vy: float = 0.0
    yaw_rate: float = 0.0
    steer: float = 0.0
    drive_force: float = 0.0
    brake_force: float = 0.0

    def __post_init__(self) -> None:
        for name, v in zip(("x", "y", "yaw", "vx", "vy", "yaw_rate", "steer", "drive_force", "brake_force"),
                           astuple(self), strict=True):
            if not np.isfinite(v):
                raise ValueError(f"initial state: {name} must be finite, got {v!r}")

    @property
    def speed(self) -> float:
        """Planar speed of the centre of mass [m/s]."""
        return float(np.hypot(self.vx, self.vy))

    def to_array(self) -> np.ndarray:
        """The plant vector ``z``."""
        return np.array(astuple(self), dtype=np.float64)

    @classmethod
    def from_array(cls, z: np.ndarray) -> VehicleState:
        """A view of a plant vector, yaw wrapped to (-pi, pi]."""
        v = [float(a) for a in z[:NZ]]
        v[YAW] = wrap_angle(v[YAW])
        return cls(x=v[X], y=v[Y], yaw=v[YAW], vx=v[VX], vy=v[VY], yaw_rate=v[YAW_RATE],
                   steer=v[STEER], drive_force=v[DRIVE], brake_force=v[BRAKE])
