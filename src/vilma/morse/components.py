"""vilma's car as a MORSE robot: component table, sensor dicts, actuator commands.

Sensors (MORSE field names and units, ``reference/morse-protocol.md`` section 7;
``timestamp`` is sim time [s] from the start of the run, as MORSE with
``use_relative_time(True)``; frames are ENU world and body x forward, y left, z up):

============ ================== ====================================================================
component    vilma reading      fields
============ ================== ====================================================================
pose         ``pose``           ``x, y, z`` [m], ``yaw, pitch, roll`` [rad]. vilma's car points along
                                body +x, so yaw is the ENU yaw (from +x); the original's Blender car
                                pointed along +y, its MORSE yaw was this yaw - pi/2.
velocity     ``velocity``       ``linear_velocity`` [m/s] body, ``angular_velocity`` [rad/s] body,
                                ``world_linear_velocity`` [m/s] world
gps          ``gps``            MORSE ``simple`` level: ``x, y, z`` [m], local ENU (noisy as vilma's GPS)
imu          ``imu``            ``angular_velocity`` [rad/s], ``linear_acceleration`` [m/s^2] incl.
                                gravity (+9.81 on z at rest), ``magnetic_field`` [nT]: vilma has no
                                magnetometer, so this is :data:`EARTH_FIELD_ENU` rotated into the body
                                frame by the IMU orientation (no noise)
wheelspeed   ``wheel_speed``    ``w_fl, w_fr, w_rl, w_rr`` [rad/s], positive rolling forward (the
                                original's custom ``Wheelspeed`` sensor)
odometry     ``odometry``       MORSE ``integrated`` level: ``x, y, z, yaw, pitch, roll`` relative to
                                the pose at the first reading (MORSE: the start pose), and ``vx, vy, vz``
                                [m/s] in that start frame, ``wz, wy, wx`` [rad/s]; re-based when the
                                sim time goes back (a reset)
laser        ``laser`` (3D      MORSE ``LaserScanner`` (``Sick``), ``raw`` level: ``point_list`` [[x, y, z],
             plant's scans)     ...] [m] in the laser frame (x forward, y left, z up) and ``range_list``
                                [m], one entry a ray in vilma's scan order. As MORSE: a ray without a
                                hit has the point [0, 0, 0] and the range ``laser_range`` (the laser's
                                reach), not vilma's inf: MORSE clients written for its scanner test
                                ``range < laser_range``. Only when the simulator has a laser.
============ ================== ====================================================================

Actuators (IN datastreams, sticky: the last command holds until the next):

* ``steer_force`` (MORSE ``SteerForce``): ``steer`` [rad], front wheels, positive left (Bullet's
  ``setSteeringValue`` sign, also vilma's); ``force`` in MORSE engine-force units, **negative forward**;
  ``brake`` >= 0. Becomes ``ActuatorCommand(longitudinal=FORCE, steer=steer,
  drive=-force * STEER_FORCE_UNIT, brake=brake * STEER_BRAKE_UNIT)``. MORSE's Bullet forces act on a
  toy-mass Hummer, so there is no physical unit to copy; the units are chosen so that MORSE's own
  SteerForce test (force -20 for 3 s then brake 10 for 1 s: about 8.5 m; then force -40 for 3 s and
  brake for 2 s: about 28 m in total) gives the same distances on vilma's 1211 kg car (8.6 m, 28.2 m).
  Its reversing leg (force +10 for 11 s: back to about the start) is not matched by any one linear
  unit: vilma's car reverses about 47 m there, as its drive force and resistance imply.
* ``motion`` (MORSE ``MotionVW``): ``v`` [m/s] forward, ``w`` [rad/s] counter-clockwise. A car cannot
  turn in place, so it follows the curvature ``w / v``: steer = atan(L w / v) (L the wheelbase; the
  sign of ``w`` at full lock when ``v`` = 0), and a speed loop a = k (v - v_measured) each frame,
  clamped to the car's accel/decel limits, sent in ``accel`` mode (``force`` mode with m a plus the
  rolling/drag feed-forward when reversing). Services ``set_speed [v, w]`` and ``stop``.

Every component with socket services but the laser also answers MORSE's object services
(:data:`OBJECT_SERVICES`): ``get_properties`` (its MORSE class's properties, e.g. :data:`COMPUTATION_MODE`)
and ``get_configurations`` (their values, and where it sits on the robot: :func:`mounts`).

The original program's services on the robot (``VilmaClass``; ``reference/vilma-original.md`` 5):
see :class:`OriginalCar`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

import numpy as np

from vilma.core.messages import (
    ActuatorCommand,
    GpsFix,
    Imu,
    Longitudinal,
    Odometry,
    PointCloud,
    Pose,
    Velocity,
    WheelSpeeds,
)
from vilma.sensors import SensorSuite
from vilma.sensors.base import Readings
from vilma.vehicle.params import VehicleParams

STEER_FORCE_UNIT = 105.0
"""Drive force at the wheels of one SteerForce ``force`` unit [N] (sign flipped: MORSE's negative is forward)."""
STEER_BRAKE_UNIT = 1000.0
"""Total brake force of one SteerForce ``brake`` unit [N]."""
MOTION_SPEED_GAIN = 1.5
"""MotionVW speed loop gain: acceleration request per m/s of speed error [1/s]."""

_DECL, _INCL, _TOTAL = math.radians(-21.5), math.radians(-37.5), 23_000.0
EARTH_FIELD_ENU = (
    _TOTAL * math.cos(_INCL) * math.sin(_DECL),
    _TOTAL * math.cos(_INCL) * math.cos(_DECL),
    -_TOTAL * math.sin(_INCL),
)
"""Earth's magnetic field (east, north, up) [nT] near Campinas (the GPS origin), WMM approximate: declination
-21.5 deg, inclination -37.5 deg, total 23 000 nT."""

STREAM_MANAGER = "morse.middleware.socket_datastream.SocketDatastreamManager"
SERVICE_MANAGER = "morse.middleware.socket_request_manager.SocketRequestManager"


Property = tuple[str, tuple[Any, str, str, str]]
"""A MORSE component property (``add_property``): its name, and its value, type name, documentation and Python
attribute, the tuple MORSE's ``get_properties`` answers."""

COMPUTATION_MODE: Property = ("ComputationMode", (
    "Velocity", "string", "Kind of computation, can be one of ['Velocity', 'Position']. Only robot with dynamic and "
    "Velocity control can choose Velocity computation. Default choice is Velocity for robot with physics, and "
    "Position for others", "_type"))
"""MORSE's ``Velocity`` and ``IMU`` property, which they resolve to ``Velocity`` on a robot with physics: vilma's
velocities and accelerations also come from the car's dynamics, not from differenced positions."""
CONTROL_TYPE: Property = ("ControlType", (
    "Velocity", "string", "Kind of control, can be one of ['Velocity', 'Position']", "_type"))
"""MORSE's ``MotionVW`` property: ``v`` and ``w`` are speeds."""

OBJECT_SERVICES = ("get_properties", "get_configurations")
"""MORSE's services of every object with a socket service interface (``morse.core.object.Object``), but
``set_property``: vilma's properties are its configuration, fixed while it runs."""
_SENSOR_SERVICES = ("get_local_data", *OBJECT_SERVICES)


@dataclass(frozen=True, slots=True)
class ComponentSpec:
    """One MORSE component of the robot: ``name`` (after ``robot.``), MORSE ``type``, stream direction
    (``OUT`` sensor, ``IN`` actuator), the vilma reading it streams (sensors), its socket services, its MORSE
    properties."""

    name: str
    type: str
    direction: str
    reading: str | None = None
    services: tuple[str, ...] = ()
    properties: tuple[Property, ...] = ()


COMPONENTS: tuple[ComponentSpec, ...] = (
    ComponentSpec("pose", "Pose", "OUT", "pose", _SENSOR_SERVICES),
    ComponentSpec("velocity", "Velocity", "OUT", "velocity", _SENSOR_SERVICES, (COMPUTATION_MODE,)),
    ComponentSpec("gps", "GPS", "OUT", "gps", _SENSOR_SERVICES),
    ComponentSpec("imu", "IMU", "OUT", "imu", _SENSOR_SERVICES, (COMPUTATION_MODE,)),
    ComponentSpec("wheelspeed", "Wheelspeed", "OUT", "wheel_speed", _SENSOR_SERVICES),
    ComponentSpec("odometry", "IntegratedOdometry", "OUT", "odometry", _SENSOR_SERVICES),
    ComponentSpec("steer_force", "SteerForce", "IN"),
    ComponentSpec("motion", "MotionVW", "IN", None, ("set_speed", "stop", *OBJECT_SERVICES), (CONTROL_TYPE,)),
)
"""The components in registration order: stream ports are given in this order (60000, 60001, ...)."""
WORLD_COMPONENTS: tuple[ComponentSpec, ...] = (
    ComponentSpec("laser", "LaserScanner", "OUT", "laser", ("get_local_data",)),
)
"""Components of the 3D plant's world sensors (``reading``: the topic they stream), registered after
:data:`COMPONENTS` when the simulator has that sensor."""
LASER_RANGE = 30.0
"""Default reach of the laser [m] (MORSE's ``Sick``): the range of a ray without a hit."""


def components(world_topics: Collection[str] = ()) -> tuple[ComponentSpec, ...]:
    """The robot's components in registration order: :data:`COMPONENTS`, then those of
    :data:`WORLD_COMPONENTS` whose topic is in ``world_topics`` (other world topics, cameras, are not served)."""
    return COMPONENTS + tuple(c for c in WORLD_COMPONENTS if c.reading in world_topics)


def mounts(sensors: SensorSuite) -> dict[str, tuple[float, float, float]]:
    """Where the components of :data:`COMPONENTS` sit in the robot's frame (body x forward, y left, z up, from the
    centre of mass, which the pose reports) [m], by name: the GPS antenna and the IMU at their offsets, the others
    at the centre of mass (what they measure, or act on). Every component's axes are the body's."""
    at = dict.fromkeys((c.name for c in COMPONENTS), (0.0, 0.0, 0.0))
    for name, params in (("gps", sensors.gps), ("imu", sensors.imu)):
        if params is not None:
            at[name] = tuple(map(float, params.offset))
    return at


ROBOT_TYPE = "VilmaClass"
"""The robot's MORSE type (the original's ``classpath="VilmaClass.VilmaClass"``)."""
ROBOT_SERVICES = ("steer", "controlpower", "power", "brake", "autonomous", "status")
"""The original program's services on the robot."""


# -- sensors ------------------------------------------------------------------------------------------------


def _index(message: type) -> dict[str, int]:
    return {name: i for i, name in enumerate(message.__struct_fields__[1:])}


def rotate(q: tuple[float, float, float, float], v: tuple[float, float, float]) -> list[float]:
    """Vector ``v`` rotated by the orientation ``q`` = (x, y, z, w), normalised first: R(q) v (body -> world)."""
    x, y, z, w = q
    n = math.sqrt(x * x + y * y + z * z + w * w) or 1.0
    x, y, z, w = x / n, y / n, z / n, w / n
    vx, vy, vz = v
    # v' = v + 2 w (u x v) + 2 u x (u x v), u = (x, y, z)
    cx, cy, cz = y * vz - z * vy, z * vx - x * vz, x * vy - y * vx
    return [vx + 2.0 * (w * cx + y * cz - z * cy),
            vy + 2.0 * (w * cy + z * cx - x * cz),
            vz + 2.0 * (w * cz + x * cy - y * cx)]


def _rotate_into_body(q: tuple[float, float, float, float], v: tuple[float, float, float]) -> list[float]:
    """World vector ``v`` in the body frame of orientation ``q`` = (x, y, z, w): R(q)^T v."""
    return rotate((-q[0], -q[1], -q[2], q[3]), v)  # the conjugate rotates world -> body


def _wrap(a: float) -> float:
    w = (a + math.pi) % (2.0 * math.pi) - math.pi
    return w + 2.0 * math.pi if w <= -math.pi else w


class SensorMapper:
    """Turns vilma readings into MORSE ``local_data`` dicts, one per reading row.

    Holds the odometry start pose (MORSE's integrated odometry is relative to it).
    """

    def __init__(self) -> None:
        self._odo_origin: tuple[float, float, float] | None = None
        self._odo_last_ns = -1
        self._builders: dict[type, Callable[[float, list[float]], dict[str, Any]]] = {
            Pose: self._pose, Velocity: self._velocity, GpsFix: self._gps, Imu: self._imu,
            WheelSpeeds: self._wheels,
        }
        self._idx = {m: _index(m) for m in (*self._builders, Odometry)}

    def reset(self) -> None:
        """Forget the odometry start pose (the next odometry reading becomes the new start)."""
        self._odo_origin = None
        self._odo_last_ns = -1

    def dicts(self, readings: Readings) -> list[dict[str, Any]]:
        """One MORSE dict per row of ``readings``, oldest first (empty for a message type MORSE lacks)."""
        stamps = readings.stamp_ns.tolist()
        rows = np.asarray(readings.values, dtype=float).tolist()
        if readings.message is Odometry:
            return [self._odometry(t, row) for t, row in zip(stamps, rows, strict=True)]
        build = self._builders.get(readings.message)
        if build is None:
            return []
        return [build(t / 1e9, row) for t, row in zip(stamps, rows, strict=True)]

    def _pose(self, t: float, r: list[float]) -> dict[str, Any]:
        i = self._idx[Pose]
        return {"timestamp": t, "x": r[i["x"]], "y": r[i["y"]], "z": r[i["z"]],
                "yaw": r[i["yaw"]], "pitch": r[i["pitch"]], "roll": r[i["roll"]]}

    def _velocity(self, t: float, r: list[float]) -> dict[str, Any]:
        i = self._idx[Velocity]
        return {"timestamp": t,
                "linear_velocity": [r[i["vx"]], r[i["vy"]], r[i["vz"]]],
                "angular_velocity": [r[i["wx"]], r[i["wy"]], r[i["wz"]]],
                "world_linear_velocity": [r[i["vx_world"]], r[i["vy_world"]], r[i["vz_world"]]]}

    def _gps(self, t: float, r: list[float]) -> dict[str, Any]:
        i = self._idx[GpsFix]
        return {"timestamp": t, "x": r[i["x"]], "y": r[i["y"]], "z": r[i["z"]]}

    def _imu(self, t: float, r: list[float]) -> dict[str, Any]:
        i = self._idx[Imu]
        q = (r[i["qx"]], r[i["qy"]], r[i["qz"]], r[i["qw"]])
        return {"timestamp": t,
                "angular_velocity": [r[i["wx"]], r[i["wy"]], r[i["wz"]]],
                "linear_acceleration": [r[i["ax"]], r[i["ay"]], r[i["az"]]],
                "magnetic_field": _rotate_into_body(q, EARTH_FIELD_ENU)}

    def _wheels(self, t: float, r: list[float]) -> dict[str, Any]:
        i = self._idx[WheelSpeeds]
        return {"timestamp": t, "w_fl": r[i["fl"]], "w_fr": r[i["fr"]], "w_rl": r[i["rl"]], "w_rr": r[i["rr"]]}

    def _odometry(self, stamp_ns: int, r: list[float]) -> dict[str, Any]:
        i = self._idx[Odometry]
        x, y, yaw = r[i["x"]], r[i["y"]], r[i["yaw"]]
        if self._odo_origin is None or stamp_ns <= self._odo_last_ns:  # first reading, or the sim was reset
            self._odo_origin = (x, y, yaw)
        self._odo_last_ns = stamp_ns
        x0, y0, yaw0 = self._odo_origin
        c, s = math.cos(yaw0), math.sin(yaw0)
        dx, dy = x - x0, y - y0
        rel_yaw = _wrap(yaw - yaw0)
        speed = r[i["speed"]]
        return {"timestamp": stamp_ns / 1e9, "x": c * dx + s * dy, "y": -s * dx + c * dy, "z": 0.0,
                "yaw": rel_yaw, "pitch": 0.0, "roll": 0.0,
                "vx": speed * math.cos(rel_yaw), "vy": speed * math.sin(rel_yaw), "vz": 0.0,
                "wz": r[i["yaw_rate"]], "wy": 0.0, "wx": 0.0}


def laser_dict(scan: PointCloud, laser_range: float = LASER_RANGE) -> dict[str, Any]:
    """MORSE ``LaserScanner`` local data of a vilma scan: ``timestamp`` [s], ``point_list`` and ``range_list``,
    one entry a ray (see the module docstring: [0, 0, 0] and ``laser_range`` [m] for a ray without a hit).

    Raises:
        ValueError: a malformed scan (not whole float32 triples, or not one point a finite range).
    """
    if not isinstance(scan, PointCloud):
        raise ValueError(f"a {type(scan).__name__}, not a PointCloud")
    if len(scan.points) % 12 or len(scan.ranges) % 4:
        raise ValueError(f"{len(scan.points)} bytes of points and {len(scan.ranges)} of ranges are not whole "
                         f"float32 xyz triples and float32 ranges")
    ranges = np.frombuffer(scan.ranges, "<f4").astype(float)
    hit = np.isfinite(ranges)
    points = np.zeros((len(ranges), 3))
    if int(hit.sum()) != len(scan.points) // 12:
        raise ValueError(f"{len(scan.points) // 12} points for {int(hit.sum())} finite ranges")
    points[hit] = np.frombuffer(scan.points, "<f4").reshape(-1, 3)
    return {"timestamp": scan.stamp_ns / 1e9, "point_list": points.tolist(),
            "range_list": np.where(hit, ranges, laser_range).tolist()}


# -- actuators ------------------------------------------------------------------------------------------------


class CommandValueError(ValueError):
    """An actuator message or service argument that cannot become a command; the text says which and why."""


def finite(name: str, value: Any, *, allow_inf: bool = False) -> float:
    """``value`` as a float, or :class:`CommandValueError` naming ``name`` (bools and NaN refused)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise CommandValueError(f"{name} must be a number, got {value!r}")
    v = float(value)
    if math.isnan(v) or (math.isinf(v) and not (allow_inf and v > 0)):
        raise CommandValueError(f"{name} must be a finite number, got {v}")
    return v


def flag(name: str, value: Any) -> int:
    """An on/off flag of the original services: 0 or 1 (``True``/``False`` accepted)."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, int | float) and value in (0, 1):
        return int(value)
    raise CommandValueError(f"{name} must be 0 or 1, got {value!r}")


def _fields(what: str, msg: Any, names: tuple[str, ...]) -> dict[str, float]:
    """Numeric fields of an actuator message dict; missing ones are 0 (vilma merges with defaults)."""
    if not isinstance(msg, dict):
        raise CommandValueError(f"{what} message must be a JSON object like "
                                f"{{{', '.join(f'{n!r}: 0.0' for n in names)}}}".replace("'", '"') + f", got {msg!r}")
    unknown = sorted(set(msg) - set(names))
    if unknown:
        raise CommandValueError(f"{what} message has unknown field(s) {', '.join(map(str, unknown))}: "
                                f"use {', '.join(names)}")
    return {n: finite(f"{what} field '{n}'", msg.get(n, 0.0)) for n in names}


def steer_force_command(msg: Any, stamp_ns: int) -> ActuatorCommand:
    """A SteerForce message ``{"steer": rad, "force": MORSE units (negative forward), "brake": >= 0}``
    as a ``force``-mode command (units: :data:`STEER_FORCE_UNIT`, :data:`STEER_BRAKE_UNIT`)."""
    f = _fields("SteerForce", msg, ("steer", "force", "brake"))
    for name, unit in (("force", STEER_FORCE_UNIT), ("brake", STEER_BRAKE_UNIT)):
        if math.isinf(f[name] * unit):  # a finite value whose force in newtons overflows
            raise CommandValueError(f"SteerForce field '{name}' {f[name]:g} is out of range: at most "
                                    f"{sys.float_info.max / unit:.3g} in magnitude")
    return ActuatorCommand(stamp_ns=stamp_ns, steer=f["steer"], longitudinal=Longitudinal.FORCE,
                           drive=-f["force"] * STEER_FORCE_UNIT, brake=f["brake"] * STEER_BRAKE_UNIT)


def motion_target(msg: Any) -> tuple[float, float]:
    """A MotionVW message ``{"v": m/s, "w": rad/s}`` as ``(v, w)``."""
    f = _fields("MotionVW", msg, ("v", "w"))
    return f["v"], f["w"]


def motion_command(v: float, w: float, speed: float, vehicle: VehicleParams, stamp_ns: int) -> ActuatorCommand:
    """The command that drives the car toward MotionVW ``(v, w)`` from the measured forward ``speed`` [m/s].

    Steer = atan(L w / v) (the curvature w/v of the path), limited to the car's lock; speed by
    a = k (v - speed), k = :data:`MOTION_SPEED_GAIN`, clamped to the actuators' accel/decel limits.
    Forward (v >= 0, not rolling back) uses ``accel`` mode (it adds the car's resistance and brakes
    when a < 0); reversing uses ``force`` mode with m a plus the resistance, signed.
    """
    lock = vehicle.max_steer
    # at standstill there is no path curvature: full lock toward w
    steer = math.atan(vehicle.wheelbase * w / v) if abs(v) > 1e-6 else math.copysign(lock, w) if w else 0.0
    steer = min(max(steer, -lock), lock)
    a = vehicle.actuators
    accel = min(max(MOTION_SPEED_GAIN * (v - speed), -a.max_decel), a.max_accel)
    if v >= 0.0 and speed > -0.05:
        return ActuatorCommand(stamp_ns=stamp_ns, steer=steer, longitudinal=Longitudinal.ACCEL, drive=accel)
    drive = vehicle.mass * accel + (math.copysign(vehicle.resistance(abs(speed)), speed) if speed else 0.0)
    drive = min(max(drive, -vehicle.max_drive_force), vehicle.max_drive_force)
    return ActuatorCommand(stamp_ns=stamp_ns, steer=steer, longitudinal=Longitudinal.FORCE, drive=drive)


@dataclass
class OriginalCar:
    """The original ``VilmaClass`` services as game properties, and what Bullet holds between ticks.

    Fields are the original's game properties in snake case (``steering`` is ``Steering``,
    ``steering_amount`` is ``steeringAmount``, ``control_power`` is ``controlPower``, ``power_flag`` is
    ``Power``, ``brake_flag`` is ``Brake`` ...), with the original's defaults.

    The services only set properties; the original's per-tick scripts then applied them:
    ``steering.py`` sets the wheel angle to ``steeringAmount`` while ``Steering == 1``;
    ``controlPower.py`` / ``power.py`` set the engine to ``powerAmount`` below ``velocityAmount``
    while ``controlPower == 1`` / ``Power == 1``; ``brake.py`` brakes ``brakeAmount`` while
    ``Brake == 1``. Bullet keeps the last steering, engine force and braking when a flag is 0, so
    this class does too (``held_*``): ``steer [0, x]`` leaves the wheels where they are and
    ``controlpower [0, p, v]`` leaves the engine force (the original GUI sends
    ``controlpower [1, 0, 100]`` first to zero it). The command is ``power`` mode
    (:class:`~vilma.core.messages.Longitudinal`): ``drive`` = held ``powerAmount``,
    ``velocity_limit`` = ``velocityAmount`` while a power flag is 1 (else no limit, as the
    original did not check the speed then), ``brake`` = held ``brakeAmount``, ``steer`` = held
    ``steeringAmount`` [rad, positive left], ``autonomous`` = ``autonomous != 0``.

    Differences: ``power`` shares vilma's overspeed brake with ``controlpower`` (the original's
    ``power.py`` only cut the engine); the original's ``brake`` service always failed (it read an
    undefined ``brakeState``) and here works as intended.
    """

    autonomous: float = 0.0
    brake_flag: int = 0
    brake_amount: float = 0.0
    power_flag: int = 0
    power_amount: float = 1000.0
    velocity_amount: float = 20.0
    steering: int = 0
    steering_amount: float = 0.0
    control_power: int = 0
    held_steer: float = 0.0
    held_power: float = 0.0
    held_brake: float = 0.0

    def steer(self, flag_: Any, amount: Any) -> None:
        """``steer [Steering, steeringAmount rad]``."""
        f, a = flag("Steering", flag_), finite("steeringAmount", amount)
        self.steering, self.steering_amount = f, a
        self._tick()

    def controlpower(self, flag_: Any, power: Any, velocity: Any) -> None:
        """``controlpower [controlPower, powerAmount (original units), velocityAmount m/s]``."""
        f, pw = flag("controlPower", flag_), finite("powerAmount", power)
        v = finite("velocityAmount", velocity, allow_inf=True)
        self.control_power, self.power_amount, self.velocity_amount = f, pw, v
        self._tick()

    def power(self, flag_: Any, power: Any, velocity: Any) -> None:
        """``power [Power, powerAmount (original units), velocityAmount m/s]``."""
        f, pw = flag("Power", flag_), finite("powerAmount", power)
        v = finite("velocityAmount", velocity, allow_inf=True)
        self.power_flag, self.power_amount, self.velocity_amount = f, pw, v
        self._tick()

    def brake(self, flag_: Any, amount: Any) -> None:
        """``brake [Brake, brakeAmount (original units per wheel)]``."""
        f, a = flag("Brake", flag_), finite("brakeAmount", amount)
        self.brake_flag, self.brake_amount = f, a
        self._tick()

    def set_autonomous(self, a: Any) -> None:
        """``autonomous [a]``: nonzero marks the commands autonomous (the simulator's watchdog then guards them)."""
        self.autonomous = finite("autonomous", a)

    def _tick(self) -> None:
        """What the original's per-tick scripts apply from the properties."""
        if self.steering == 1:
            self.held_steer = self.steering_amount
        if self.control_power == 1 or self.power_flag == 1:
            self.held_power = self.power_amount
        if self.brake_flag == 1:
            self.held_brake = self.brake_amount

    def command(self, stamp_ns: int) -> ActuatorCommand:
        """The command the properties and held values amount to."""
        engine = self.control_power == 1 or self.power_flag == 1
        return ActuatorCommand(stamp_ns=stamp_ns, steer=self.held_steer, longitudinal=Longitudinal.POWER,
                               drive=self.held_power, brake=self.held_brake,
                               velocity_limit=self.velocity_amount if engine else math.inf,
                               autonomous=self.autonomous != 0)
