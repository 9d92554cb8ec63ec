"""Typed messages exchanged between simulator, driver, GUI and recorders.

Every message carries sim time as ``stamp_ns`` [ns]. Fields are SI units in
the frames of :mod:`vilma.core.geometry` (ENU world, body x forward, y left).
Positional field order is part of the format: sensors build messages from
rows of their sample arrays in that order.
"""

from __future__ import annotations

import math
from enum import StrEnum
from typing import Annotated

import msgspec

from vilma.core.geometry import quaternion_from_euler

MAX_ORDER_POINTS = 100_000
"""The most points (and speeds) in one order: a 50 km path at 0.5 m spacing."""
MAX_NAME_CHARS = 64
"""The longest action, controller name, gain name or text value in an order [characters]."""
MAX_FILE_NAME_CHARS = 4096
"""The longest file name in an order [characters] (Linux's ``PATH_MAX``)."""
MAX_GAINS = 32
"""The most controllers in a ``tune`` order, and the most fields of one (vilma's have at most 16)."""

_Name = Annotated[str, msgspec.Meta(max_length=MAX_NAME_CHARS)]
_Gains = Annotated[dict[_Name, bool | int | float | _Name], msgspec.Meta(max_length=MAX_GAINS)]


class Message(msgspec.Struct, frozen=True, tag=True, array_like=True):
    """Base of every message: ``stamp_ns`` is sim time [ns]."""

    stamp_ns: int


class Pose(Message, frozen=True):
    """Ground-truth pose of the car's reference point: position [m], ZYX Euler angles [rad]."""

    x: float
    y: float
    z: float
    roll: float
    pitch: float
    yaw: float

    @property
    def quaternion(self) -> tuple[float, float, float, float]:
        """Orientation as ``(x, y, z, w)``."""
        return tuple(float(q) for q in quaternion_from_euler(self.roll, self.pitch, self.yaw))


class Velocity(Message, frozen=True):
    """Linear velocity in body and world frames [m/s] and body angular velocity [rad/s]."""

    vx: float
    vy: float
    vz: float
    vx_world: float
    vy_world: float
    vz_world: float
    wx: float
    wy: float
    wz: float

    @property
    def speed(self) -> float:
        """Planar speed [m/s]."""
        return math.hypot(self.vx, self.vy)


class GpsFix(Message, frozen=True):
    """GPS fix: WGS84 latitude, longitude [deg], altitude [m], and local ENU x, y, z [m]."""

    latitude: float
    longitude: float
    altitude: float
    x: float
    y: float
    z: float


class Imu(Message, frozen=True):
    """IMU: specific force incl. gravity [m/s^2], angular velocity [rad/s] (body), orientation quaternion."""

    ax: float
    ay: float
    az: float
    wx: float
    wy: float
    wz: float
    qx: float
    qy: float
    qz: float
    qw: float


class WheelSpeeds(Message, frozen=True):
    """Wheel angular speeds [rad/s], positive rolling forward (order FL, FR, RL, RR as the original)."""

    fl: float
    fr: float
    rl: float
    rr: float


class Odometry(Message, frozen=True):
    """Dead-reckoned pose from wheel speeds: position [m], yaw [rad], speed [m/s], yaw rate [rad/s]."""

    x: float
    y: float
    yaw: float
    speed: float
    yaw_rate: float


class ActuatorState(Message, frozen=True):
    """What the car applies now: front-wheel angle [rad], drive force [N] at the wheels, brake force [N]."""

    steer: float
    drive_force: float
    brake_force: float


class Longitudinal(StrEnum):
    """How :class:`ActuatorCommand` ``drive`` and ``brake`` are read.

    - ``force``: ``drive`` is the drive force at the wheels [N] (negative drives
      backwards), ``brake`` the total brake force [N].
    - ``accel``: ``drive`` is an acceleration request [m/s^2] met by the car's
      own drive/brake split; ``brake`` an extra brake force [N].
    - ``power``: the original VILMA semantics: ``drive`` is ``powerAmount``
      (engine force on each of the 4 wheels, original units), ``velocity_limit``
      is ``velocityAmount`` [m/s] (above it the engine is cut and brake 30 is
      applied), ``brake`` is ``brakeAmount`` (original units per wheel).
    """

    FORCE = "force"
    ACCEL = "accel"
    POWER = "power"


class ActuatorCommand(Message, frozen=True, kw_only=True):
    """Actuator command. ``steer`` is the front-wheel angle [rad], positive left.

    ``autonomous`` marks commands from a self-driver: while the last command was
    autonomous, the simulator's watchdog stops the car when commands stop.
    """

    stamp_ns: int = 0
    steer: float = 0.0
    longitudinal: Longitudinal = Longitudinal.FORCE
    drive: float = 0.0
    brake: float = 0.0
    velocity_limit: float = math.inf
    autonomous: bool = False


class SimStatus(Message, frozen=True, kw_only=True):
    """Simulator status: real-time factor (sim s per wall s), autonomy and watchdog flags, and the collisions
    of the car's body with the world's obstacles since the last reset (count, and the last obstacle hit)."""

    real_time_factor: float = math.nan
    autonomous: bool = False
    watchdog_tripped: bool = False
    collisions: int = 0
    last_collision: str = ""


class DriverStatus(Message, frozen=True):
    """The self-driver's state: mode, target and measured speed [m/s], position on the path, errors.

    ``index`` is the active waypoint or path segment, ``progress`` and
    ``remaining`` the arc length done and left [m], ``cross_track`` the signed
    distance from the path [m] (positive left; NaN without a path).
    """

    mode: str
    target_speed: float
    speed: float
    index: int
    progress: float
    remaining: float
    cross_track: float
    arrived: bool
    error: str


class PoseEstimate(Message, frozen=True):
    """Estimated pose of the centre of mass: x, y [m], yaw [rad], forward speed [m/s], yaw rate [rad/s],
    and 1-sigma uncertainties of x, y [m] and yaw [rad] (0 for the exact pose)."""

    x: float
    y: float
    yaw: float
    speed: float
    yaw_rate: float
    std_x: float
    std_y: float
    std_yaw: float


class DriverOrder(Message, frozen=True, kw_only=True):
    """An order to the self-driver (the original GUI's Automatic Driving buttons).

    ``action``: ``manual``, ``set_speed`` (``speed`` [m/s]), ``hold_speed``, ``go_to`` (``x``, ``y`` [m],
    ``speed``), ``follow`` (``points`` [[x, y], ...] [m] with their ``speeds`` [m/s], or the name of a
    trajectory ``file`` in the driver's data folder; ``speed``, or NaN for the points' or the file's own speeds),
    ``plan`` (to the goal ``x``, ``y`` [m] along the route ``points`` with their ``speeds``, or a straight route from
    the car at ``speed``: :mod:`vilma.bus.plan_node`), ``tune`` (the driver's ``speed_controller`` and
    ``path_controller`` by name, and ``gains``: controller name -> {field: value}). Sizes are capped
    (``MAX_ORDER_POINTS``, ``MAX_NAME_CHARS``, ``MAX_FILE_NAME_CHARS``, ``MAX_GAINS``): a decoder refuses more before
    building anything.
    """

    stamp_ns: int = 0
    action: _Name
    speed: float = math.nan
    x: float = math.nan
    y: float = math.nan
    points: Annotated[list[tuple[float, float]], msgspec.Meta(max_length=MAX_ORDER_POINTS)] = []
    speeds: Annotated[list[float], msgspec.Meta(max_length=MAX_ORDER_POINTS)] = []
    file: Annotated[str, msgspec.Meta(max_length=MAX_FILE_NAME_CHARS)] = ""
    speed_controller: _Name = ""
    path_controller: _Name = ""
    gains: Annotated[dict[_Name, _Gains], msgspec.Meta(max_length=MAX_GAINS)] = {}


class SimControl(Message, frozen=True, kw_only=True):
    """An order to the simulator: ``action`` ``reset`` (to the start pose) or ``status``."""

    stamp_ns: int = 0
    action: _Name


class Reply(Message, frozen=True, kw_only=True):
    """The answer to an order: ``ok``, or the one-line ``error`` saying why not."""

    stamp_ns: int = 0
    ok: bool
    error: str = ""


class Image(Message, frozen=True):
    """A camera image (the fields of ``foxglove.RawImage``): ``height`` rows of ``step`` bytes from the
    top-left pixel. ``encoding``: ``rgb8`` (3 bytes a pixel) or ``32FC1`` (depth along the optical axis [m],
    float32 little-endian; inf where nothing is within range). ``frame_id``: the camera's frame."""

    frame_id: str
    width: int
    height: int
    encoding: str
    step: int
    data: bytes


class PointCloud(Message, frozen=True):
    """One laser scan in the laser's frame ``frame_id`` (x forward, y left, z up): ``points`` the hits as
    float32 little-endian ``x, y, z`` [m] triples; ``ranges`` float32 [m] per ray in scan order (inf: no hit
    within range), so the points are the finite ranges along their rays."""

    frame_id: str
    points: bytes
    ranges: bytes


class ObjectState(msgspec.Struct, frozen=True):
    """One object around the car, world frame: its id in the scenario, position [m] of its reference point,
    orientation [rad, counter-clockwise from +x], speed along it [m/s], and outline's length and width [m]."""

    id: int
    x: float
    y: float
    yaw: float
    speed: float
    length: float
    width: float


class ObjectList(Message, frozen=True):
    """The objects within the objects sensor's reach (the scenario's true obstacles, with noise)."""

    objects: list[ObjectState] = []


MAX_TRACKS = 256
"""The most tracked objects in one :class:`TrackList`."""
MAX_PLAN_PATHS = 256
"""The most paths of each kind (drawn candidates, predictions) in one :class:`LocalPlan`: as many as tracks."""
MAX_PATH_POINTS = 401
"""The most points in one planned, candidate or predicted path: a planner's longest horizon, 400 steps."""
MAX_REASON_CHARS = 1000
"""The longest reason of a :class:`LocalPlan` [characters]."""

_Floats = Annotated[list[float], msgspec.Meta(max_length=MAX_PATH_POINTS)]


def _one_length(what: str, **columns: list) -> None:
    """Raises ValueError unless the ``columns`` of a path (named by their fields) are equally long; a decoder
    turns it into a refused frame, so no reader gets a path whose x and y do not pair up."""
    if len({len(c) for c in columns.values()}) > 1:
        counts = ", ".join(f"{len(c)} {name}" for name, c in columns.items())
        raise ValueError(f"{what} of {counts}: give as many of each")


class TrackedObject(msgspec.Struct, frozen=True):
    """One object as the car's perception tracks it, world frame: its track id, box centre [m], orientation [rad],
    velocity [m/s], box length and width [m], the covariance of (x, y, vx, vy) row by row (16 values, SI units
    squared), and how long it has been tracked [s]."""

    id: int
    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    length: float
    width: float
    covariance: Annotated[list[float], msgspec.Meta(max_length=16)]
    age: float


class TrackList(Message, frozen=True):
    """The objects the car perceives (``perception/objects``): its tracks, from the laser or the objects sensor."""

    source: str
    """``laser`` or ``truth``: what the objects were perceived with."""
    objects: Annotated[list[TrackedObject], msgspec.Meta(max_length=MAX_TRACKS)] = []


class PlannedPath(msgspec.Struct, frozen=True):
    """A path of a plan [m]: a candidate (``status`` 0 free, 1 infeasible, 2 colliding; ``id`` -1) or an object's
    predicted future (``id`` its track, ``status`` 0), at the plan's times; ``x`` and ``y`` equally long (checked)."""

    id: int
    status: int
    x: _Floats
    y: _Floats

    def __post_init__(self) -> None:
        _one_length("a path", x=self.x, y=self.y)


class LocalPlan(Message, frozen=True):
    """A planning cycle (``planning/plan``): the trajectory chosen, from the cycle's time on at steps of ``dt`` [s]
    (positions [m], speeds [m/s]), its ``mode`` (``velocity``, ``follow``, ``stop`` or ``fallback``) and
    ``reason`` (why the fallback), a sample of the candidates evaluated and the predicted futures of the
    objects; ``planning_ms``: the wall time the cycle took [ms] (NaN: not measured). ``x``, ``y`` and ``speed`` are
    equally long (checked, as each path's)."""

    mode: _Name
    reason: Annotated[str, msgspec.Meta(max_length=MAX_REASON_CHARS)]
    dt: float
    x: _Floats
    y: _Floats
    speed: _Floats
    candidates: Annotated[list[PlannedPath], msgspec.Meta(max_length=MAX_PLAN_PATHS)] = []
    predictions: Annotated[list[PlannedPath], msgspec.Meta(max_length=MAX_PLAN_PATHS)] = []
    planning_ms: float = math.nan

    def __post_init__(self) -> None:
        _one_length("a trajectory", x=self.x, y=self.y, speed=self.speed)
