"""Stepping the MuJoCo car with vilma's actuator outputs, and reading it back as vilma's plant state."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from vilma.plant3d.car_model import CORNERS, TIMESTEP, car_xml
from vilma.plant3d.road import TrafficMover, road_xml, traffic_xml
from vilma.plant3d.world import World
from vilma.vehicle.actuators import actuate
from vilma.vehicle.models.common import V_SIGN
from vilma.vehicle.params import VehicleParams, plant_consts
from vilma.vehicle.state import NX, VehicleState

if TYPE_CHECKING:  # the roads extra
    from vilma.world.road_view import LaneletLines
    from vilma.world.traffic import Traffic

COLLISION_GAP = 0.5
"""A touch of an obstacle is a new collision if the car was off it this long [s] (a bounce is the same one)."""


def ackermann(steer: float, wheelbase: float, track: float) -> tuple[float, float]:
    """Left and right front-wheel angles [rad] that share the turning centre of a bicycle front angle ``steer``."""
    if abs(steer) < 1e-9:
        return 0.0, 0.0
    radius = wheelbase / math.tan(steer)  # signed: positive turning left
    return math.atan(wheelbase / (radius - track / 2)), math.atan(wheelbase / (radius + track / 2))


class MujocoPlant:
    """vilma's car in MuJoCo (see :mod:`vilma.plant3d.car_model`).

    :meth:`step` holds the actuator outputs ``steer`` [rad, bicycle front angle], ``drive`` [N at the
    wheels] and ``brake`` [N, >= 0] for a while, limited and split between the axles as the planar
    models do; drag and rolling resistance act on the chassis. Each step checks the contacts: a car part
    that starts touching an obstacle of ``world`` is a collision (:data:`COLLISION_GAP`;
    :attr:`collisions`, :attr:`last_collision`).
    ``cameras``: MJCF of the world sensors inside the chassis; ``imu``: the IMU's place in the body [m].
    A CommonRoad scenario adds its ``road`` (drawn on the ground) and its ``traffic`` (``traffic<id>``, obstacles
    too), at the traffic's time ``traffic_t0`` [s] at sim time 0 (:mod:`vilma.plant3d.road`).
    """

    def __init__(self, params: VehicleParams, world: World = World(), cameras: str = "",
                 imu: tuple[float, float, float] = (0.0, 0.0, 0.0), road: tuple[LaneletLines, ...] = (),
                 traffic: Traffic | None = None, traffic_t0: float = 0.0) -> None:
        self.params, self.world = params, world
        assets, surface = road_xml(road)
        scene = (assets, surface + (traffic_xml(traffic) if traffic is not None else ""))
        self.model = mujoco.MjModel.from_xml_string(car_xml(params, world, cameras, imu, scene))
        self.data = mujoco.MjData(self.model)
        m = self.model
        ids = traffic.ids.tolist() if traffic is not None else []
        names = [*world.obstacle_names(), *(f"traffic{i}" for i in ids)]
        self._obstacles = {m.geom(f"obstacle:{n}").id: n for n in names}
        self._traffic = TrafficMover(m, traffic, traffic_t0) if traffic is not None else None
        self._obstacle_ids = np.array(sorted(self._obstacles), dtype=np.int32)
        self._chassis = m.body("chassis").id
        self._car_geoms = np.flatnonzero(m.body_rootid[m.geom_bodyid] == self._chassis)
        # the chassis's free joint comes first (qpos[0:7], qvel[0:6]), the drive motors then the steering servos
        assert m.joint("chassis").qposadr[0] == 0 and m.joint("chassis").dofadr[0] == 0
        assert [m.actuator(i).name for i in range(6)] == [*(f"drive_{c}" for c in CORNERS), "steer_fl", "steer_fr"]
        self._xmat = self.data.xmat[self._chassis]
        self._force = self.data.xfrc_applied[self._chassis]
        # views kept: each read of an MjData attribute makes a new one, and a step reads a dozen
        d, accel, gyro = self.data, m.sensor("imu_accel").adr[0], m.sensor("imu_gyro").adr[0]
        self._qpos, self._qvel, self._qacc, self._ctrl = d.qpos[0:7], d.qvel[0:6], d.qacc[0:6], d.ctrl
        self._accel, self._gyro = d.sensordata[accel:accel + 3], d.sensordata[gyro:gyro + 3]
        self._spin_dof = np.array([m.joint(f"spin_{c}").dofadr[0] for c in CORNERS])
        self._susp_q = np.array([m.joint(f"susp_{c}").qposadr[0] for c in CORNERS])
        self._steer_q = np.array([m.joint(f"steer_{c}").qposadr[0] for c in ("fl", "fr")])
        self._k_drag = 0.5 * params.air_density * params.drag_area
        self._f_roll = params.rolling_resistance * params.mass * 9.81
        self._consts = np.array(plant_consts(params))  # crosses into compiled code far cheaper than the tuple
        self.reset()

    def reset(self, state: VehicleState = VehicleState()) -> None:
        """Put the car at ``state`` (position, heading, body velocities), settled on its springs."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        self._brake = math.nan
        d.qpos[0:3] = (state.x, state.y, self.params.suspension.cg_height)
        d.qpos[3:7] = (math.cos(state.yaw / 2), 0.0, 0.0, math.sin(state.yaw / 2))
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        d.qvel[0:3] = (state.vx * c - state.vy * s, state.vx * s + state.vy * c, 0.0)
        d.qvel[5] = state.yaw_rate
        d.qvel[self._spin_dof] = state.vx / self.params.wheel_radius
        self.set_controls(state.steer, 0.0, 0.0)
        d.qpos[self._steer_q] = ackermann(state.steer, self.params.wheelbase, self.params.track)
        if self._traffic is not None:
            self._traffic.move(d, 0.0)
        mujoco.mj_forward(m, d)
        self.collisions, self.last_collision = 0, ""
        self._touched: dict[int, float] = {}
        """Obstacle geom id -> MuJoCo time it was last touched [s]."""

    def set_controls(self, steer: float, drive: float, brake: float) -> None:
        """Hold ``steer`` [rad], ``drive`` [N] and ``brake`` [N] from now on."""
        p = self.params
        xm, (vx_w, vy_w, vz_w) = self._xmat.tolist(), self._qvel[0:3].tolist()
        vx = xm[0] * vx_w + xm[3] * vy_w + xm[6] * vz_w  # along body x
        f = min(max(drive, -p.max_drive_force), p.max_drive_force)
        f_power = p.max_power / max(abs(vx), 1e-3)
        f = min(max(f, -f_power), f_power)
        r = p.wheel_radius
        front, rear = p.drive_split_front * f / 2 * r, (1 - p.drive_split_front) * f / 2 * r
        self._ctrl[:] = (front, front, rear, rear, *ackermann(steer, p.wheelbase, p.track))
        if brake != self._brake:
            self._brake = brake
            b = min(max(brake, 0.0), p.max_brake_force)
            bf, br = p.brake_split_front * b / 2 * r, (1 - p.brake_split_front) * b / 2 * r
            self.model.dof_frictionloss[self._spin_dof] = (bf, bf, br, br)
        resist = self._k_drag * vx * abs(vx) + self._f_roll * math.tanh(vx / V_SIGN)
        n = math.hypot(xm[0], xm[3]) or 1.0
        self._force[0:2] = (-resist * xm[0] / n, -resist * xm[3] / n)

    def step(self, steer: float, drive: float, brake: float, dt: float) -> None:
        """Advance ``dt`` [s] (a whole number of MuJoCo steps) with these actuator outputs."""
        self.set_controls(steer, drive, brake)
        nstep = max(1, round(dt / TIMESTEP))
        if self._traffic is not None:  # where the traffic is at the block's end, when the sensors look
            self._traffic.move(self.data, self.data.time + nstep * TIMESTEP)
        mujoco.mj_step(self.model, self.data, nstep)
        mujoco.mj_kinematics(self.model, self.data)  # body poses at the step's end, as qpos (cameras see them)
        if len(self._obstacle_ids):
            self._check_contacts()

    def _check_contacts(self) -> None:
        d = self.data
        pairs = d.contact.geom[:d.ncon]
        pairs = pairs[np.isin(pairs, self._car_geoms).any(axis=1)]  # a cone on the ground is no collision
        for g in set(pairs[np.isin(pairs, self._obstacle_ids)].tolist()):
            if d.time - self._touched.get(g, -math.inf) > COLLISION_GAP:
                self.collisions += 1
                self.last_collision = self._obstacles[g]
            self._touched[g] = d.time

    def advance(self, z: np.ndarray, mode: int, cmd: np.ndarray, dt: float, n: int, tick: int,
                periods: np.ndarray, out_z: np.ndarray, out_dx: np.ndarray, out_tick: np.ndarray,
                out_3d: np.ndarray | None = None) -> int:
        """:func:`vilma.vehicle.integrate.advance` on this plant: ``n`` steps of ``dt`` [s] with the command
        ``(mode, cmd)`` through vilma's actuators; ``z`` (planar state and actuator outputs) is updated in
        place and the sensors' sample ticks are recorded, with :meth:`extras` in ``out_3d`` when given.
        Returns the number of rows written."""
        u = z[NX:].copy()
        x = self.planar_state()
        j = 0
        periods = periods.tolist()
        for i in range(1, n + 1):
            actuate(mode, cmd, x, u, self._consts, dt)
            self.step(*u.tolist(), dt)
            x = self.planar_state()
            if any((tick + i) % p == 0 for p in periods):
                out_z[j, :NX], out_z[j, NX:] = x, u
                out_dx[j] = self.derivative(x)
                if out_3d is not None:
                    out_3d[j] = self.extras()
                out_tick[j] = tick + i
                j += 1
        z[:NX], z[NX:] = x, u
        return j

    def extras(self) -> tuple[float, ...]:
        """What only the 3D plant has, in the layout of :data:`vilma.vehicle.state.N3` (height above rest, roll,
        pitch, vertical velocity, body angular velocity, specific force at the IMU)."""
        z, roll, pitch = self.attitude()
        return (z - self.params.suspension.cg_height, roll, pitch, float(self._qvel[2]), *self._gyro.tolist(),
                *self._accel.tolist())

    def derivative(self, state: tuple[float, ...] | None = None) -> tuple[float, float, float, float, float, float]:
        """Time derivative of :meth:`planar_state` now (as the planar models' ``derivative``); ``state``: the
        planar state now, if known."""
        _, _, yaw, vx, vy, r = state or self.planar_state()
        c, s = math.cos(yaw), math.sin(yaw)
        xm = self._xmat.tolist()
        ax_w, ay_w, _, a0, a1, a2 = self._qacc.tolist()
        vx_w, vy_w = self._qvel[0:2].tolist()
        return vx_w, vy_w, r, c * ax_w + s * ay_w + vy * r, -s * ax_w + c * ay_w - vx * r, \
            xm[6] * a0 + xm[7] * a1 + xm[8] * a2

    def planar_state(self) -> tuple[float, float, float, float, float, float]:
        """``(x, y, yaw, vx, vy, yaw_rate)`` as vilma's planar models hold them (yaw from the heading of
        body x in the ground plane, velocities of the centre of mass in the heading frame)."""
        xm = self._xmat.tolist()
        vx_w, vy_w, _, w0, w1, w2 = self._qvel.tolist()  # world linear, body angular
        n = math.hypot(xm[0], xm[3]) or 1.0
        c, s = xm[0] / n, xm[3] / n
        x, y = self._qpos[0:2].tolist()
        return x, y, math.atan2(s, c), c * vx_w + s * vy_w, -s * vx_w + c * vy_w, xm[6] * w0 + xm[7] * w1 + xm[8] * w2

    def attitude(self) -> tuple[float, float, float]:
        """``(z [m] of the centre of mass, roll, pitch [rad])`` (ZYX Euler angles, roll about body x, pitch
        about body y: positive nose down)."""
        height, w, x, y, z = self._qpos[2:7].tolist()  # floats: numpy scalars are slow to compute with
        roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
        return height, roll, pitch

    def suspension(self) -> np.ndarray:
        """Suspension positions ``fl, fr, rl, rr`` [m] from the static rest position, positive in compression
        (the wheel up toward the body)."""
        return self.data.qpos[self._susp_q].copy()
