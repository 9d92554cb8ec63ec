"""Stepping the MuJoCo car with vilma's actuator outputs, and reading it back as vilma's plant state."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from vilma.plant3d import kernel
from vilma.plant3d.car_model import CORNERS, TIMESTEP, car_xml
from vilma.plant3d.kernel import ackermann
from vilma.plant3d.road import TrafficMover, road_xml, traffic_xml
from vilma.plant3d.world import World
from vilma.vehicle.params import VehicleParams
from vilma.vehicle.state import VehicleState

if TYPE_CHECKING:  # the roads extra
    from vilma.world.road_view import LaneletLines
    from vilma.world.traffic import Traffic

class MujocoPlant:
    """vilma's car in MuJoCo (see :mod:`vilma.plant3d.car_model`), stepped in compiled code
    (:mod:`vilma.plant3d.kernel`).

    :meth:`step` holds the actuator outputs ``steer`` [rad, bicycle front angle], ``drive`` [N at the
    wheels] and ``brake`` [N, >= 0] for a while, limited and split between the axles as the planar
    models do; drag and rolling resistance act on the chassis. Each step checks the contacts: a car part
    that starts touching an obstacle of ``world`` is a collision (:data:`~vilma.plant3d.kernel.COLLISION_GAP`;
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
        ids = traffic.ids.tolist() if traffic is not None else []
        self._obstacles = [*world.obstacle_names(), *(f"traffic{i}" for i in ids)]
        self.model = mujoco.MjModel.from_xml_string(car_xml(params, world, cameras, imu, scene, self._obstacles))
        self.data = mujoco.MjData(self.model)
        m, d = self.model, self.data
        self._traffic = TrafficMover(m, d, traffic, traffic_t0) if traffic is not None else None
        chassis = m.body("chassis").id
        # the chassis's free joint comes first (qpos[0:7], qvel[0:6]), the drive motors then the steering servos,
        # the accelerometer then the gyro (kernel)
        assert m.joint("chassis").qposadr[0] == 0 and m.joint("chassis").dofadr[0] == 0
        assert [m.actuator(i).name for i in range(6)] == [*(f"drive_{c}" for c in CORNERS), "steer_fl", "steer_fr"]
        assert (m.sensor("imu_accel").adr[0], m.sensor("imu_gyro").adr[0]) == (0, 3)
        # views kept: each read of an MjData attribute makes a new one
        self._xmat, self._qpos, self._qvel = d.xmat[chassis], d.qpos, d.qvel
        self._spin_dof = np.array([m.joint(f"spin_{c}").dofadr[0] for c in CORNERS])
        self._susp_q = np.array([m.joint(f"susp_{c}").qposadr[0] for c in CORNERS])
        self._steer_q = np.array([m.joint(f"steer_{c}").qposadr[0] for c in ("fl", "fr")])
        ctl = {"k_drag": 0.5 * params.air_density * params.drag_area,
               "f_roll": params.rolling_resistance * params.mass * 9.81,
               "cg_height": params.suspension.cg_height, "timestep": m.opt.timestep}
        touch = np.array([m.sensor(f"touch:{n}").adr[0] for n in self._obstacles], dtype=np.int64)
        self._touched, self._io = np.empty(len(touch)), np.empty(3)
        consts = np.array([ctl[k] if k in ctl else getattr(params, k) for k in kernel.CTL])
        self._car = (d.qpos, d.qvel, d.qacc, d.ctrl, d.sensordata, d.xfrc_applied[chassis], m.dof_frictionloss,
                     self._spin_dof, consts, touch, self._touched, self._io, kernel.MJCB_TIME)
        """:mod:`vilma.plant3d.kernel`'s car."""
        self._ptrs = (m._address, d._address)
        self._traffic_args = self._traffic.args if self._traffic is not None else None  # None: no arrays to pass
        self.reset()

    def reset(self, state: VehicleState = VehicleState()) -> None:
        """Put the car at ``state`` (position, heading, body velocities), settled on its springs."""
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        d.qpos[0:3] = (state.x, state.y, self.params.suspension.cg_height)
        d.qpos[3:7] = (math.cos(state.yaw / 2), 0.0, 0.0, math.sin(state.yaw / 2))
        c, s = math.cos(state.yaw), math.sin(state.yaw)
        d.qvel[0:3] = (state.vx * c - state.vy * s, state.vx * s + state.vy * c, 0.0)
        d.qvel[5] = state.yaw_rate
        d.qvel[self._spin_dof] = state.vx / self.params.wheel_radius
        self._io[:] = (math.nan, 0, -1)  # no brake held yet, no collision
        self._touched[:] = -math.inf
        kernel.controls(self._car, self._xmat, state.steer, 0.0, 0.0)  # the body poses are zeros now: no drag
        d.qpos[self._steer_q] = ackermann(state.steer, self.params.wheelbase, self.params.track)
        if self._traffic is not None:
            self._traffic.move(0.0)
        mujoco.mj_forward(m, d)

    @property
    def collisions(self) -> int:
        """The collisions since the reset."""
        return int(self._io[kernel.COLLISIONS])

    @property
    def last_collision(self) -> str:
        """The obstacle of the last collision ("": none since the reset)."""
        last = int(self._io[kernel.LAST])
        return self._obstacles[last] if last >= 0 else ""

    def step(self, steer: float, drive: float, brake: float, dt: float) -> None:
        """Advance ``dt`` [s] (a whole number of MuJoCo steps) with these actuator outputs."""
        kernel.hold(self._ptrs, self._car, self._traffic_args, steer, drive, brake, max(1, round(dt / TIMESTEP)),
                    self.data.time)

    def kernel_args(self, dt: float) -> tuple:
        """What :func:`vilma.plant3d.kernel.advance` takes of this plant for steps of ``dt`` [s] (a whole number of
        MuJoCo steps): its structs' addresses, its car, its traffic and the MuJoCo steps a step."""
        return self._ptrs, self._car, self._traffic_args, max(1, round(dt / TIMESTEP))

    def planar_state(self) -> tuple[float, float, float, float, float, float]:
        """``(x, y, yaw, vx, vy, yaw_rate)`` as vilma's planar models hold them (yaw from the heading of
        body x in the ground plane, velocities of the centre of mass in the heading frame)."""
        return kernel.planar_state(self._qpos, self._qvel, self._xmat)

    def attitude(self) -> tuple[float, float, float]:
        """``(z [m] of the centre of mass, roll, pitch [rad])`` (ZYX Euler angles, roll about body x, pitch
        about body y: positive nose down)."""
        return kernel.attitude(self._qpos)

    def suspension(self) -> np.ndarray:
        """Suspension positions ``fl, fr, rl, rr`` [m] from the static rest position, positive in compression
        (the wheel up toward the body)."""
        return self.data.qpos[self._susp_q].copy()
