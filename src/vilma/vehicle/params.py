"""Vehicle and actuator parameters (frozen, SI units) and named presets.

Presets:
    ``vilma``: the paper's car (the MORSE/Bullet model of the original code,
        ../shared/reference/vilma-original.md section 5). Values the original
        leaves open are marked *assumed* with the reasoning.
    ``bmw_320i``: CommonRoad vehicle parameter set 2 (BMW 320i), M. Althoff,
        M. Koschi, S. Manzinger, "CommonRoad: Composable benchmarks for motion
        planning on roads", IEEE IV 2017; values of ``parameters_vehicle2``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import NamedTuple

from vilma.core.checks import check_numbers

GRAVITY = 9.81
"""Gravitational acceleration [m/s^2]."""

# The range of each number of a car: every wheeled vehicle there is, from a 1:10 model car (about 1 kg, wheelbase
# 0.3 m, wheel radius 0.05 m, a few hundred watts) to the largest mining truck (about 800 t laden, 20 m long, 10 m
# wide, 2 m wheels, 4.6 MW, Cd*A near 80 m^2), with a factor of 10 to 1000 beyond both ends, so that no car one may
# model is refused while a typo by powers of ten (mass 1e300) is. Within them the derived values stay far from a
# float's range: the axle loads, the top speed's Cardano terms (p^3 <= 1e42, q^2 <= 1e30) and the plant's forces.
LIMITS = {
    "mass": (0.1, 1e7),  # [kg]
    "yaw_inertia": (1e-4, 1e10),  # [kg m^2], about m (length^2 + width^2) / 12
    **dict.fromkeys(("cg_to_front", "cg_to_rear", "track", "length", "width", "wheel_radius"), (1e-3, 100.0)),  # [m]
    **dict.fromkeys(("cornering_stiffness_front", "cornering_stiffness_rear"), (0.01, 1e10)),  # [N/rad], 5-30 loads
    "tyre_shape": (0.1, 10.0),  # Pacejka's C, 1.3 for the lateral force
    "tyre_curvature": (-100.0, 1.0),  # Pacejka's E, at most 1
    "friction": (0.01, 10.0),  # ice 0.05, dry asphalt 1, racing slicks under 2
    "max_power": (0.1, 1e9),  # [W]
    **dict.fromkeys(("max_drive_force", "max_brake_force", "power_unit_force", "brake_unit_force"), (1e-3, 1e9)),  # [N]
    **dict.fromkeys(("drive_split_front", "brake_split_front"), (0.0, 1.0)),  # shares
    "drag_area": (1e-4, 1e3),  # [m^2] (0: no drag)
    "air_density": (0.01, 10.0),  # [kg/m^3], Mars' ground 0.02, sea level 1.225 (0: no air)
    "rolling_resistance": (1e-4, 1.0),  # (0: none)
    **dict.fromkeys(("blend_speed_low", "blend_speed_high"), (1e-3, 1e3)),  # [m/s] (low 0: dynamic from rest)
}
"""The ``[low, high]`` of each number of :class:`VehicleParams` (0 is also taken where a field may be off)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class ActuatorParams:
    """Actuator dynamics between a command and what the car applies."""

    steer_time_constant: float = 0.05
    """First-order lag of the front-wheel angle [s] (0: none)."""
    steer_rate_limit: float = 0.8
    """Largest front-wheel angle rate [rad/s]."""
    drive_time_constant: float = 0.1
    """First-order lag of the drive force [s] (0: none)."""
    brake_time_constant: float = 0.1
    """First-order lag of the brake force [s] (0: none)."""
    dead_time: float = 0.0
    """Delay from a command's arrival to its effect [s], rounded to whole physics steps."""
    max_accel: float = 4.0
    """Largest acceleration request accepted in ``accel`` mode [m/s^2]."""
    max_decel: float = 8.0
    """Largest deceleration request accepted in ``accel`` mode [m/s^2]."""
    stop_deceleration: float = 3.0
    """Deceleration of the watchdog's controlled stop [m/s^2]."""

    def __post_init__(self) -> None:
        check_numbers(self, "actuator", positive=("steer_rate_limit", "max_accel", "max_decel", "stop_deceleration"),
                      non_negative=True)


@dataclass(frozen=True, slots=True, kw_only=True)
class SuspensionParams:
    """What the 3D plant adds to a planar car: heights, suspension, wheel mass and body inertia."""

    cg_height: float = 0.55
    """Centre of mass above the ground at rest [m]."""
    stiffness: float = 36_000.0
    """Spring rate of one corner [N/m]."""
    damping: float = 2_600.0
    """Damper rate of one corner [N s/m]."""
    travel: float = 0.12
    """Wheel travel each way from the rest position to the bump stop [m]."""
    wheel_mass: float = 20.0
    """One wheel with its hub and brake, unsprung [kg]."""
    wheel_width: float = 0.2
    """Tyre width [m]."""
    roll_inertia: float = 0.0
    """Moment of inertia of the whole car about its longitudinal axis [kg m^2] (0: a box estimate)."""
    pitch_inertia: float = 0.0
    """Moment of inertia about the lateral axis [kg m^2] (0: a box estimate)."""

    def __post_init__(self) -> None:
        check_numbers(self, "suspension", positive=("cg_height", "stiffness", "damping", "travel", "wheel_mass",
                                                    "wheel_width"), non_negative=True)


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleParams:
    """A car for the planar models. Lengths [m], masses [kg], forces [N], angles [rad]."""

    name: str
    mass: float
    """Total mass [kg]."""
    yaw_inertia: float
    """Moment of inertia about the vertical axis through the centre of mass [kg m^2]."""
    cg_to_front: float
    """Centre of mass to front axle [m]."""
    cg_to_rear: float
    """Centre of mass to rear axle [m]."""
    track: float
    """Distance between left and right wheel centres [m]."""
    length: float
    """Length of the body's outline, a box centred midway between the axles [m] (collision checks)."""
    width: float
    """Width of the body's outline [m]."""
    wheel_radius: float
    """Effective rolling radius [m]."""
    max_steer: float
    """Front-wheel angle limit [rad] (symmetric)."""
    cornering_stiffness_front: float
    """Front axle (both tyres) cornering stiffness [N/rad]."""
    cornering_stiffness_rear: float
    """Rear axle (both tyres) cornering stiffness [N/rad]."""
    tyre_shape: float = 1.3
    """Pacejka shape factor C of the lateral force [-]."""
    tyre_curvature: float = 0.0
    """Pacejka curvature factor E of the lateral force [-], <= 1."""
    friction: float = 1.0
    """Tyre-road friction coefficient [-]."""
    max_power: float
    """Largest drive power at the wheels [W]."""
    max_drive_force: float
    """Largest drive force at the wheels [N] (engine torque limit, before traction)."""
    drive_split_front: float
    """Share of the drive force on the front axle [-] (0 rear drive, 1 front drive)."""
    brake_split_front: float = 0.6
    """Share of the brake force on the front axle [-]."""
    max_brake_force: float
    """Largest total brake force [N] (before traction)."""
    drag_area: float
    """Drag coefficient times frontal area, Cd*A [m^2]."""
    air_density: float = 1.225
    """Air density [kg/m^3]."""
    rolling_resistance: float = 0.013
    """Rolling resistance coefficient [-]."""
    blend_speed_low: float = 1.0
    """Below this speed the single-track model is purely kinematic [m/s]."""
    blend_speed_high: float = 3.0
    """Above this speed the single-track model is purely dynamic [m/s]."""
    power_unit_force: float
    """Total drive force of one original ``powerAmount`` unit on four wheels [N] (``power`` mode)."""
    brake_unit_force: float = 30.0
    """Brake force of one original ``brakeAmount`` unit on one wheel [N] (``power`` mode).

    Bullet's ``applyBraking`` value is an impulse per physics step [N s]; at
    MORSE's 30 steps/s that is 30 N per unit."""
    actuators: ActuatorParams = ActuatorParams()
    suspension: SuspensionParams = SuspensionParams()
    """Used by the 3D plant only."""

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, float | int) and not isinstance(v, bool) and not math.isfinite(v):
                raise ValueError(f"vehicle '{self.name}': {f.name} must be finite, got {v!r}")
        positive = ("mass", "yaw_inertia", "cg_to_front", "cg_to_rear", "track", "length", "width", "wheel_radius",
                    "max_steer", "cornering_stiffness_front", "cornering_stiffness_rear", "tyre_shape", "friction",
                    "max_power", "max_drive_force", "max_brake_force", "power_unit_force")
        for name in positive:
            if getattr(self, name) <= 0:
                raise ValueError(f"vehicle '{self.name}': {name} must be > 0, got {getattr(self, name)!r}")
        for name, (low, high) in LIMITS.items():
            if getattr(self, name) and not low <= getattr(self, name) <= high:
                raise ValueError(f"vehicle '{self.name}': {name} must be within [{low:g}, {high:g}] (any wheeled "
                                 f"vehicle's, vilma.vehicle.params.LIMITS), got {getattr(self, name)!r}")
        if not 0 <= self.blend_speed_low < self.blend_speed_high:
            raise ValueError(f"vehicle '{self.name}': need 0 <= blend_speed_low < blend_speed_high")
        if not self.max_steer < math.pi / 2:
            raise ValueError(f"vehicle '{self.name}': max_steer must be below pi/2 rad")

    @property
    def wheelbase(self) -> float:
        """Front to rear axle [m]."""
        return self.cg_to_front + self.cg_to_rear

    @property
    def body_offset(self) -> float:
        """How far the body's outline's centre lies ahead of the centre of mass [m] (negative: behind)."""
        return (self.cg_to_front - self.cg_to_rear) / 2

    @property
    def load_front(self) -> float:
        """Static front axle load [N]."""
        return self.mass * GRAVITY * self.cg_to_rear / self.wheelbase

    @property
    def load_rear(self) -> float:
        """Static rear axle load [N]."""
        return self.mass * GRAVITY * self.cg_to_front / self.wheelbase

    @property
    def understeer_gradient(self) -> float:
        """Linear understeer gradient K [rad/(m/s^2)]: delta = L/R + K a_y (> 0 understeer)."""
        return self.mass / self.wheelbase * (
            self.cg_to_rear / self.cornering_stiffness_front - self.cg_to_front / self.cornering_stiffness_rear
        )

    @property
    def top_speed(self) -> float:
        """Fastest speed on level ground [m/s], where ``max_power`` only just overcomes drag and rolling
        resistance: ``k v^3 + f v = P`` (Cardano's root; inf for a car with no resistance). A drive force
        or traction limit may hold the car below it."""
        k = 0.5 * self.air_density * self.drag_area
        f = self.rolling_resistance * self.mass * GRAVITY
        if k <= 0:
            return self.max_power / f if f > 0 else math.inf
        q, p = self.max_power / (2 * k), f / (3 * k)  # v^3 + 3 p v - 2 q = 0
        a = math.cbrt(q + math.sqrt(q * q + p**3))
        # a - p / a, as 2 q over a sum of positive terms: no cancellation when rolling dominates (p^3 >> q^2)
        return 2 * q / (a * a + p + (p / a) ** 2)

    def resistance(self, speed: float) -> float:
        """Drag plus rolling resistance at a forward ``speed`` > 0 [N]."""
        return 0.5 * self.air_density * self.drag_area * speed * speed + self.rolling_resistance * self.mass * GRAVITY


def vilma() -> VehicleParams:
    """The paper's car, from the original MORSE model (vilma-original.md section 5).

    From the original: mass 1211 kg; wheels at y = +1.1 (front) and -1.35 (rear)
    from the chassis origin, taken as the centre of mass; track 0.77 + 0.8 =
    1.57 m; wheel radius 0.4 m; steering limit 0.6 rad (GUI side); drive on all
    four wheels (``applyEngineForce`` on each); "power 1000 takes 0 to 100 km/h
    in about 10.8 s".

    Assumed (the original leaves them open; a compact hatchback of 1.2 t):
    yaw inertia m*lf*lr (dynamic index 1); cornering stiffness 75 / 110 kN/rad
    front / rear, which with this mass split gives an understeer gradient of
    about 2.3 deg/g (characteristic speed about 25 m/s, typical of such cars);
    Cd*A = 0.32 * 2.1 m^2; rolling resistance 0.013; 85 kW at the wheels;
    friction 1.0 (dry asphalt; the .blend's ground had 0.5 with Bullet grip 30).

    Steering as MORSE/Bullet applied it: at once (no lag; a 10 rad/s rate
    limit). A real steering actuator is slower; model it with
    :class:`ActuatorParams` (the paper's Turn-Wheels controller needs the
    fast one: with a 50 ms lag and 1 rad/s it loses the path).

    Calibrated: ``power_unit_force`` = 3.43 N per unit so that power 1000 gives
    0 to 100 km/h in 10.8 s on this model (tests/vehicle check it).

    Suspension (3D plant), from Bullet's raycast vehicle, whose suspension
    coefficients are per kg of chassis (``btRaycastVehicle`` multiplies the
    force by the chassis mass): stiffness 30 is 30 * 1211 = 36 330 N/m per
    corner (1.7 Hz with a quarter of the car, 82 mm static sag); the
    template's damping 1.0 (rebound) and 80 (compression) are 1 211 and
    96 880 N s/m, the second rigid for practical purposes, so one symmetric
    damper of 2 650 N s/m (damping ratio 0.4 of a corner, *assumed*) stands
    in. Rest length 0.15 m minus the static sag leaves about 70 mm of travel.
    The centre of mass is the chassis origin, 0.786 m above the ground.
    """
    return VehicleParams(
        name="vilma",
        mass=1211.0,
        yaw_inertia=1211.0 * 1.1 * 1.35,
        cg_to_front=1.1,
        cg_to_rear=1.35,
        track=1.57,
        length=1.1 + 1.35 + 1.5,  # the 3D plant's body: the wheelbase and 0.75 m overhangs, the track and a tyre
        width=1.57 + 0.2,
        wheel_radius=0.4,
        max_steer=0.6,
        cornering_stiffness_front=75_000.0,
        cornering_stiffness_rear=110_000.0,
        friction=1.0,
        max_power=85_000.0,
        max_drive_force=6_000.0,
        drive_split_front=0.5,
        max_brake_force=12_000.0,
        drag_area=0.32 * 2.1,
        rolling_resistance=0.013,
        power_unit_force=3.43,
        actuators=ActuatorParams(steer_time_constant=0.0, steer_rate_limit=10.0),
        suspension=SuspensionParams(cg_height=0.786, stiffness=30.0 * 1211.0, damping=2650.0, travel=0.07),
    )


def bmw_320i() -> VehicleParams:
    """BMW 320i, CommonRoad vehicle parameter set 2 (Althoff et al., IEEE IV 2017).

    From the set: m = 1093.3 kg, I_z = 1791.6 kg m^2, a = 1.156 m, b = 1.422 m,
    track 1.387 m (front), length 4.508 m, width 1.610 m, R_w = 0.344 m, steering limit 1.066 rad and rate
    0.4 rad/s, friction 1.0489, cornering stiffness 20.89 /rad per unit axle
    load (C_Sf = C_Sr), lateral shape 1.3507, rear drive (T_se = 0), brake
    split 0.66 front (T_sb), a_max 11.5 m/s^2 and switching speed 7.319 m/s, so
    drive force m*a_max and power m*a_max*v_switch = 92 kW.

    Assumed (not in the set): Cd*A = 0.30 * 2.0 m^2, rolling resistance 0.013;
    ``power`` mode uses the vilma calibration (3.43 N per unit).
    """
    m, a, b = 1093.3, 1.156, 1.422
    load_f, load_r = m * GRAVITY * b / (a + b), m * GRAVITY * a / (a + b)
    return VehicleParams(
        name="bmw_320i",
        mass=m,
        yaw_inertia=1791.6,
        cg_to_front=a,
        cg_to_rear=b,
        track=1.387,
        length=4.508,
        width=1.610,
        wheel_radius=0.344,
        max_steer=1.066,
        cornering_stiffness_front=20.89 * load_f,
        cornering_stiffness_rear=20.89 * load_r,
        tyre_shape=1.3507,
        friction=1.0489,
        max_power=m * 11.5 * 7.319,
        max_drive_force=m * 11.5,
        drive_split_front=0.0,
        brake_split_front=0.66,
        max_brake_force=m * 11.5,
        drag_area=0.30 * 2.0,
        power_unit_force=3.43,
        actuators=ActuatorParams(steer_rate_limit=0.4),
    )


PRESETS = {"vilma": vilma, "bmw_320i": bmw_320i}
"""Named presets: name -> constructor."""


def preset(name: str) -> VehicleParams:
    """The preset called ``name``; a clear error lists the known ones."""
    try:
        return PRESETS[name]()
    except KeyError:
        raise ValueError(f"unknown vehicle preset {name!r}; known: {', '.join(sorted(PRESETS))}") from None


class PlantConsts(NamedTuple):
    """Flat float constants handed to the compiled dynamics (derived from :class:`VehicleParams`)."""

    m: float
    iz: float
    lf: float
    lr: float
    tw: float
    rw: float
    cf: float
    cr: float
    shape: float
    curv: float
    mu: float
    fzf: float
    fzr: float
    p_max: float
    fd_max: float
    split_d: float
    split_b: float
    fb_max: float
    k_drag: float
    f_roll: float
    v_lo: float
    v_hi: float
    max_steer: float
    power_unit: float
    brake_unit: float
    tau_steer: float
    rate_steer: float
    tau_drive: float
    tau_brake: float
    stop_decel: float


def plant_consts(p: VehicleParams) -> PlantConsts:
    """Flatten parameters for the compiled plant."""
    a = p.actuators
    return PlantConsts(
        m=p.mass, iz=p.yaw_inertia, lf=p.cg_to_front, lr=p.cg_to_rear, tw=p.track, rw=p.wheel_radius,
        cf=p.cornering_stiffness_front, cr=p.cornering_stiffness_rear, shape=p.tyre_shape,
        curv=p.tyre_curvature, mu=p.friction, fzf=p.load_front, fzr=p.load_rear, p_max=p.max_power,
        fd_max=p.max_drive_force, split_d=p.drive_split_front, split_b=p.brake_split_front,
        fb_max=p.max_brake_force, k_drag=0.5 * p.air_density * p.drag_area,
        f_roll=p.rolling_resistance * p.mass * GRAVITY, v_lo=p.blend_speed_low, v_hi=p.blend_speed_high,
        max_steer=p.max_steer, power_unit=p.power_unit_force, brake_unit=p.brake_unit_force,
        tau_steer=a.steer_time_constant, rate_steer=a.steer_rate_limit, tau_drive=a.drive_time_constant,
        tau_brake=a.brake_time_constant, stop_decel=a.stop_deceleration,
    )
