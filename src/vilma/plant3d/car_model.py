"""MJCF of vilma's car and its world, generated from the vehicle parameters.

Frames as everywhere in vilma: world ENU (z up), body x forward, y left, z up. The chassis is a
free body whose inertial frame is the centre of mass; each corner hangs on a vertical slide joint
(the suspension: spring ``stiffness``, damper ``damping``, bump stops at +-``travel``), the front
corners steer on vertical hinges (Ackermann angles are set by :class:`~vilma.plant3d.MujocoPlant`),
and every wheel spins on a hinge about its axle, driven by a torque motor and braked by joint
friction. Tyres are ellipsoids (round in the wheel plane, the tyre's width across) touching the ground
at one point, so a body that rolls or pitches does not lever itself on the tyre edges (a cylinder would add
a camber stiffness no real suspension has), with the car's friction coefficient.
"""

from __future__ import annotations

from vilma.plant3d.world import World, fmt, world_xml
from vilma.vehicle.params import GRAVITY, VehicleParams

CORNERS = ("fl", "fr", "rl", "rr")
"""Corner names, in the order of the wheel-speed sensor."""
BODY_LENGTH_OVERHANG = 1.5
"""Front plus rear overhang of the body beyond the axles, for the box estimate of its inertia [m]."""
BODY_HEIGHT = 1.4
"""Body height for the box estimate of its inertia [m]."""
TIMESTEP = 0.005
"""MuJoCo step [s]: two per vilma physics step of 10 ms."""


def corner_positions(p: VehicleParams) -> dict[str, tuple[float, float]]:
    """Wheel centres in the body frame, relative to the centre of mass ``(x, y)`` [m]."""
    h = p.track / 2
    return {"fl": (p.cg_to_front, h), "fr": (p.cg_to_front, -h), "rl": (-p.cg_to_rear, h), "rr": (-p.cg_to_rear, -h)}


def sprung_inertia(p: VehicleParams) -> tuple[float, float, float, float]:
    """Sprung mass [kg] and its principal inertia ``(roll, pitch, yaw)`` [kg m^2] about the centre of mass.

    Yaw: the car's ``yaw_inertia`` less the wheels' share; roll and pitch: the suspension's values, or a
    uniform box of the wheelbase plus overhangs, the track plus a tyre, and :data:`BODY_HEIGHT`.
    """
    s = p.suspension
    mw = s.wheel_mass
    ms = p.mass - 4 * mw
    wheels_z = sum(mw * (x * x + y * y) for x, y in corner_positions(p).values())
    length, width = p.wheelbase + BODY_LENGTH_OVERHANG, p.track + s.wheel_width
    roll = s.roll_inertia or ms * (width ** 2 + BODY_HEIGHT ** 2) / 12
    pitch = s.pitch_inertia or ms * (length ** 2 + BODY_HEIGHT ** 2) / 12
    return ms, roll, pitch, max(p.yaw_inertia - wheels_z, 0.1 * p.yaw_inertia)


def spring_preload(p: VehicleParams, corner: str) -> float:
    """Static load of the sprung mass on one corner's spring [N] (the axle load shared by its two wheels)."""
    ms = p.mass - 4 * p.suspension.wheel_mass
    share = p.cg_to_rear if corner[0] == "f" else p.cg_to_front
    return ms * GRAVITY * share / p.wheelbase / 2


def car_xml(p: VehicleParams, world: World = World(), cameras: str = "",
            imu: tuple[float, float, float] = (0.0, 0.0, 0.0), scene: tuple[str, str] = ("", ""),
            touch: tuple[str, ...] = ()) -> str:
    """The MJCF text of the car at the origin on ``world``; ``cameras``: extra MJCF inside the chassis body;
    ``imu``: where the accelerometer and gyro sit in the body frame from the centre of mass [m]; ``scene``: more
    ``(assets, worldbody elements)`` (a road and its traffic, :mod:`vilma.plant3d.road`); ``touch``: the obstacles
    (geoms ``obstacle:<name>``) whose contact with the car a sensor ``touch:<name>`` reports (> 0 while touching)."""
    s = p.suspension
    r, hw = p.wheel_radius, s.wheel_width / 2
    ms, ixx, iyy, izz = sprung_inertia(p)
    mw = s.wheel_mass
    wheel_inertia = fmt(mw * (3 * r * r + 4 * hw * hw) / 12, mw * r * r / 2, mw * (3 * r * r + 4 * hw * hw) / 12)
    lock = p.max_steer + 0.2
    corners = []
    for name, (x, y) in corner_positions(p).items():
        ref = -spring_preload(p, name) / s.stiffness
        wheel = (f'<body name="wheel_{name}"><joint name="spin_{name}" type="hinge" axis="0 1 0" damping="0.01"/>'
                 f'<inertial pos="0 0 0" mass="{mw:.6g}" diaginertia="{wheel_inertia}"/>'
                 f'<geom name="tyre_{name}" type="ellipsoid" size="{fmt(r, hw, r)}" class="tyre"/>'
                 f'<geom type="box" size="{fmt(r * 0.7, hw * 1.02, 0.03)}" class="mark"/></body>')
        if name[0] == "f":
            wheel = (f'<body name="knuckle_{name}"><joint name="steer_{name}" type="hinge" axis="0 0 1" '
                     f'range="{fmt(-lock, lock)}" armature="0.5" damping="20"/>'
                     f'<inertial pos="0 0 0" mass="1" diaginertia="0.05 0.05 0.05"/>{wheel}</body>')
        corners.append(f'<body name="corner_{name}" pos="{fmt(x, y, r - s.cg_height)}">'
                       f'<joint name="susp_{name}" type="slide" axis="0 0 1" range="{fmt(-s.travel, s.travel)}" '
                       f'stiffness="{s.stiffness:.6g}" springref="{ref:.6g}" damping="{s.damping:.6g}"/>'
                       f'<inertial pos="0 0 0" mass="1" diaginertia="0.05 0.05 0.05"/>{wheel}</body>')
    body_len, body_w = p.wheelbase + BODY_LENGTH_OVERHANG, p.track + s.wheel_width
    centre_x = (p.cg_to_front - p.cg_to_rear) / 2
    assets, things = world_xml(world)
    motors = "".join(f'<motor name="drive_{c}" joint="spin_{c}"/>' for c in CORNERS)
    touches = "".join(f'<contact name="touch:{n}" subtree1="chassis" geom2="obstacle:{n}" num="1" data="found"/>'
                      for n in touch)
    steering = "".join(f'<position name="steer_{c}" joint="steer_{c}" kp="20000" kv="200"/>' for c in ("fl", "fr"))
    return f"""<mujoco model="vilma_{p.name}">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{TIMESTEP}" integrator="implicitfast" gravity="0 0 {-GRAVITY}" cone="elliptic"/>
  <visual><global offwidth="1280" offheight="960"/><quality shadowsize="0"/></visual>
  <default>
    <default class="tyre"><geom contype="1" conaffinity="1" condim="3" friction="{p.friction:.6g} 0.005 0.0001"
      rgba="0.1 0.1 0.1 1" group="1"/></default>
    <default class="mark"><geom contype="0" conaffinity="0" mass="0" rgba="0.8 0.8 0.8 1" group="1"/></default>
    <default class="obstacle"><geom contype="3" conaffinity="3" condim="3"/></default>
    <default class="terrain"><geom contype="1" conaffinity="1" condim="3" rgba="0.55 0.55 0.5 1"
      friction="{world.ground_friction:.6g} 0.005 0.0001"/></default>
  </default>
  <asset>{assets}{scene[0]}</asset>
  <worldbody>
    <light pos="0 0 50" dir="0 0 -1" directional="true"/>
    <geom name="ground" type="plane" size="0 0 1" rgba="0.45 0.5 0.45 1" contype="1" conaffinity="1"
      friction="{world.ground_friction:.6g} 0.005 0.0001"/>
    <body name="chassis" pos="0 0 {s.cg_height:.6g}">
      <freejoint name="chassis"/>
      <inertial pos="0 0 0" mass="{ms:.6g}" diaginertia="{fmt(ixx, iyy, izz)}"/>
      <geom name="body" type="box" pos="{fmt(centre_x, 0, 0.15)}" size="{fmt(body_len / 2, body_w / 2 - 0.12, 0.3)}"
        contype="2" conaffinity="2" mass="0" rgba="0.15 0.35 0.8 1" group="1"/>
      <site name="imu" pos="{fmt(*imu)}" size="0.02"/>
      {cameras}
      {"".join(corners)}
    </body>
    {things}{scene[1]}
  </worldbody>
  <actuator>{motors}{steering}</actuator>
  <sensor><accelerometer name="imu_accel" site="imu"/><gyro name="imu_gyro" site="imu"/>{touches}</sensor>
</mujoco>"""
