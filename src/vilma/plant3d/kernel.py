"""The 3D plant's stepping in compiled code: a numba loop that calls MuJoCo's C library (``mj_step``) itself.

The loop works on numpy views of the model's and the data's buffers (they share MuJoCo's memory) and on the
structs' addresses (``MjModel._address``, ``MjData._address``). MuJoCo's functions are declared to numba as
external symbols, resolved in the library the ``mujoco`` package ships (the one its bindings loaded): the compiled
code names them, not their addresses, so numba's cache holds across processes.

A car is a tuple of arrays (:class:`~vilma.plant3d.plant.MujocoPlant` holds one): ``qpos``, ``qvel``,
``qacc``, ``ctrl``, ``sensordata``, the chassis's applied force, the dofs' friction loss, the wheel spin dofs,
:data:`CTL`'s constants, the obstacles' contact sensors' addresses, when each was last touched [s], ``io``: the
brake held [N] (NaN: none yet), the collisions counted and the index of the last obstacle hit (-1: none), and
:data:`MJCB_TIME`.

MuJoCo's profiler does not run while vilma steps: the ``mujoco`` package's bindings install a timer callback
(``mjcb_time``, which fills ``MjData.timer``) that MuJoCo calls 32 times a step, 7-8 % of this car's step
(``benchmarks/plant3d.py``). :func:`block` sets it to none for its steps and puts it back after (holding the GIL:
two never overlap), so MuJoCo used from Python elsewhere in the process keeps its timers; ``MjData.timer`` does not
count vilma's steps.
"""

from __future__ import annotations

import ctypes
import glob
import math
import os

import mujoco
import numpy as np
from llvmlite import binding
from numba import njit, types

from vilma.plant3d.road import move_traffic
from vilma.vehicle.actuators import actuate
from vilma.vehicle.integrate import sampled
from vilma.vehicle.models.common import V_SIGN
from vilma.vehicle.state import NX

_LIB = ctypes.CDLL(min(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco*.[sd]*"))))
for _name in ("mj_step", "mj_kinematics", "mju_normalize4", "mju_quat2Mat"):
    binding.add_symbol(_name, ctypes.cast(getattr(_LIB, _name), ctypes.c_void_p).value)
_mj_step = types.ExternalFunction("mj_step", types.void(types.uintp, types.uintp))
_mj_kinematics = types.ExternalFunction("mj_kinematics", types.void(types.uintp, types.uintp))
_normalize4 = types.ExternalFunction("mju_normalize4", types.float64(types.voidptr))
_quat2mat = types.ExternalFunction("mju_quat2Mat", types.void(types.voidptr, types.voidptr))
MJCB_TIME = np.ctypeslib.as_array((ctypes.c_uint64 * 1).in_dll(_LIB, "mjcb_time"))
"""MuJoCo's global ``mjcb_time`` (the profiler's timer callback) as a uint64 array of one, sharing its memory: a
car's last array."""

COLLISION_GAP = 0.5
"""A touch of an obstacle is a new collision if the car was off it this long [s] (a bounce is the same one)."""
CTL = ("max_drive_force", "max_power", "wheel_radius", "drive_split_front", "brake_split_front", "max_brake_force",
       "wheelbase", "track", "k_drag", "f_roll", "cg_height", "timestep")
"""The car's constants the stepping uses, in this order (``k_drag``: 0.5 rho C_d A [kg/m]; ``f_roll``: rolling
resistance [N]; ``cg_height``: the centre of mass's rest height [m]; ``timestep``: MuJoCo's [s])."""
(_F_MAX, _P_MAX, _R, _DRIVE_FRONT, _BRAKE_FRONT, _B_MAX, _WHEELBASE, _TRACK, _K_DRAG, _F_ROLL, _CG_HEIGHT,
 _TIMESTEP) = range(len(CTL))
QPOS, QVEL, QACC, CTRL, SENSORS, FORCE, FRICTION, SPIN, CONSTS, TOUCH, TOUCHED, IO, TIMER = range(13)
"""Indices into a car tuple."""
BRAKE, COLLISIONS, LAST = range(3)
"""Indices into a car's ``io``."""
_DBL_MIN = 2.2250738585072014e-308
"""The smallest normal double."""


@njit(cache=True)
def _max(a, b):
    """Python's ``max(a, b)`` (the first of equals: signed zeros and NaN as Python has them)."""
    return b if b > a else a


@njit(cache=True)
def _min(a, b):
    """Python's ``min(a, b)``."""
    return b if b < a else a


@njit(cache=True)
def _two_product(x, y):
    """``x * y`` and its rounding error, exactly (Dekker's product)."""
    z = x * y
    c = 134217729.0 * x  # 2^27 + 1: splits a double into two halves of 26 bits
    xh = c - (c - x)
    xl = x - xh
    c = 134217729.0 * y
    yh = c - (c - y)
    yl = y - yh
    return z, ((xh * yh - z) + xh * yl + xl * yh) + xl * yl


@njit(cache=True)
def _add_exact(total, frac1, frac2, x, y):
    """``x * y`` added to the sum ``total + frac1 + frac2`` (``total`` >= the product), the errors kept."""
    hi, lo = _two_product(x, y)
    s = total + hi
    return s, frac1 + lo, frac2 + (hi - (s - total))


@njit(cache=True)
def hypot(a, b):
    """Python's ``math.hypot(a, b)`` bit for bit (CPython's vector_norm: the squares summed exactly, then a
    corrected square root); numba's is the C library's, which differs in the last bit once in 200 calls."""
    a, b = abs(a), abs(b)
    if math.isinf(a) or math.isinf(b):
        return math.inf
    if math.isnan(a) or math.isnan(b):
        return math.nan
    top, factor = max(a, b), 1.0
    if top == 0.0:
        return top
    if math.frexp(top)[1] < -1023:  # subnormals made normal first
        a, b, top, factor = a / _DBL_MIN, b / _DBL_MIN, top / _DBL_MIN, _DBL_MIN
    scale = math.ldexp(1.0, -math.frexp(top)[1])  # a power of two: lossless
    total, frac1, frac2 = 1.0, 0.0, 0.0  # total + frac1 + frac2: 1 + the sum, exactly
    for x in (a * scale, b * scale):
        total, frac1, frac2 = _add_exact(total, frac1, frac2, x, x)
    h = math.sqrt(total - 1.0 + (frac1 + frac2))
    total, frac1, frac2 = _add_exact(total, frac1, frac2, -h, h)
    return factor * ((h + (total - 1.0 + (frac1 + frac2)) / (2.0 * h)) / scale)


@njit(cache=True)
def ackermann(steer, wheelbase, track):
    """Left and right front-wheel angles [rad] that share the turning centre of a bicycle front angle ``steer``."""
    if abs(steer) < 1e-9:
        return 0.0, 0.0
    radius = wheelbase / math.tan(steer)  # signed: positive turning left
    return math.atan(wheelbase / (radius - track / 2)), math.atan(wheelbase / (radius + track / 2))


@njit(cache=True)
def body_pose(qpos, quat, mat):
    """The chassis's rotation matrix ``mat`` (9,) from its free joint's quaternion in ``qpos``, as
    ``mj_kinematics`` makes it (its own functions: the same bits), without the rest of the kinematics."""
    quat[:] = qpos[3:7]
    _normalize4(quat.ctypes.data)
    _quat2mat(mat.ctypes.data, quat.ctypes.data)


@njit(cache=True)
def controls(car, mat, steer, drive, brake):
    """Hold ``steer`` [rad], ``drive`` [N] and ``brake`` [N] from now on, limited and split between the axles as the
    planar models do, with drag and rolling resistance on the chassis (``mat``: its rotation matrix now)."""
    c, qvel, io = car[CONSTS], car[QVEL], car[IO]
    vx = mat[0] * qvel[0] + mat[3] * qvel[1] + mat[6] * qvel[2]  # along body x
    f = _min(_max(drive, -c[_F_MAX]), c[_F_MAX])
    f_power = c[_P_MAX] / _max(abs(vx), 1e-3)
    f = _min(_max(f, -f_power), f_power)
    r = c[_R]
    front, rear = c[_DRIVE_FRONT] * f / 2 * r, (1 - c[_DRIVE_FRONT]) * f / 2 * r
    left, right = ackermann(steer, c[_WHEELBASE], c[_TRACK])
    ctrl = car[CTRL]
    ctrl[0], ctrl[1], ctrl[2], ctrl[3], ctrl[4], ctrl[5] = front, front, rear, rear, left, right
    if brake != io[BRAKE]:
        io[BRAKE] = brake
        b = _min(_max(brake, 0.0), c[_B_MAX])
        bf, br = c[_BRAKE_FRONT] * b / 2 * r, (1 - c[_BRAKE_FRONT]) * b / 2 * r
        friction, spin = car[FRICTION], car[SPIN]
        friction[spin[0]], friction[spin[1]], friction[spin[2]], friction[spin[3]] = bf, bf, br, br
    resist = c[_K_DRAG] * vx * abs(vx) + c[_F_ROLL] * math.tanh(vx / V_SIGN)
    n = hypot(mat[0], mat[3]) or 1.0
    force = car[FORCE]
    force[0], force[1] = -resist * mat[0] / n, -resist * mat[3] / n


@njit(cache=True)
def block(ptrs, car, traffic, mat, steer, drive, brake, nstep, t):
    """``nstep`` MuJoCo steps from sim time ``t`` [s] with these actuator outputs held (:func:`controls`), the
    traffic (:attr:`~vilma.plant3d.road.TrafficMover.args`; None: none) where it is at the block's end (when the
    sensors look), then the collisions counted (a car part that starts touching an obstacle,
    :data:`COLLISION_GAP`); returns the sim time at the end [s]."""
    controls(car, mat, steer, drive, brake)
    dt = car[CONSTS][_TIMESTEP]
    if traffic is not None:  # compiled away without traffic
        move_traffic(t + nstep * dt, *traffic)
    timer = car[TIMER]
    profiler = timer[0]
    timer[0] = 0  # MuJoCo's profiler off for these steps (see the module's docstring)
    for _ in range(nstep):
        _mj_step(ptrs[0], ptrs[1])
        t += dt  # as mj_step counts d.time
    timer[0] = profiler
    sensors, touched, io = car[SENSORS], car[TOUCHED], car[IO]
    for k, adr in enumerate(car[TOUCH]):
        if sensors[adr] > 0:
            if t - touched[k] > COLLISION_GAP:
                io[COLLISIONS] += 1
                io[LAST] = k
            touched[k] = t
    return t


@njit(cache=True)
def hold(ptrs, car, traffic, steer, drive, brake, nstep, t):
    """:func:`block`, then the body poses of the end (cameras and the laser see them); returns the end's time."""
    quat, mat = np.empty(4), np.empty(9)
    body_pose(car[QPOS], quat, mat)
    t = block(ptrs, car, traffic, mat, steer, drive, brake, nstep, t)
    _mj_kinematics(ptrs[0], ptrs[1])
    return t


@njit(cache=True)
def planar_state(qpos, qvel, mat):
    """``(x, y, yaw, vx, vy, yaw_rate)`` as vilma's planar models hold them (yaw from the heading of body x in the
    ground plane, velocities of the centre of mass in the heading frame); ``mat``: the chassis's rotation matrix."""
    n = hypot(mat[0], mat[3]) or 1.0
    c, s = mat[0] / n, mat[3] / n
    vx_w, vy_w = qvel[0], qvel[1]
    return (qpos[0], qpos[1], math.atan2(s, c), c * vx_w + s * vy_w, -s * vx_w + c * vy_w,
            mat[6] * qvel[3] + mat[7] * qvel[4] + mat[8] * qvel[5])


@njit(cache=True)
def attitude(qpos):
    """``(z [m] of the centre of mass, roll, pitch [rad])`` (ZYX Euler angles, roll about body x, pitch about body
    y: positive nose down)."""
    w, x, y, z = qpos[3], qpos[4], qpos[5], qpos[6]
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(_max(-1.0, _min(1.0, 2 * (w * y - z * x))))
    return qpos[2], roll, pitch


@njit(cache=True)
def _record(car, mat, x, out_dx, out_3d, j):
    """Row ``j`` of the time derivative of the planar state ``x`` now (as the planar models' ``derivative``) and of
    what only the 3D plant has (:data:`vilma.vehicle.state.N3`: height above rest, roll, pitch, vertical velocity,
    body angular velocity, specific force at the IMU)."""
    qvel, qacc, sensors = car[QVEL], car[QACC], car[SENSORS]
    yaw, vx, vy, r = x[2], x[3], x[4], x[5]
    c, s = math.cos(yaw), math.sin(yaw)
    ax_w, ay_w = qacc[0], qacc[1]
    out_dx[j, 0], out_dx[j, 1], out_dx[j, 2] = qvel[0], qvel[1], r
    out_dx[j, 3], out_dx[j, 4] = c * ax_w + s * ay_w + vy * r, -s * ax_w + c * ay_w - vx * r
    out_dx[j, 5] = mat[6] * qacc[3] + mat[7] * qacc[4] + mat[8] * qacc[5]
    z, roll, pitch = attitude(car[QPOS])
    out_3d[j, 0], out_3d[j, 1], out_3d[j, 2], out_3d[j, 3] = z - car[CONSTS][_CG_HEIGHT], roll, pitch, qvel[2]
    out_3d[j, 4:7] = sensors[3:6]  # the accelerometer, then the gyro are the model's first sensors (car_model)
    out_3d[j, 7:10] = sensors[0:3]


@njit(cache=True)
def advance(ptrs, car, traffic, mode, cmd, consts, z, dt, nstep, n, tick, periods, out_z, out_dx, out_tick, out_3d,
            t, poses):
    """:func:`vilma.vehicle.integrate.advance` on the 3D plant: ``n`` steps of ``dt`` [s] (``nstep`` MuJoCo steps
    each) from sim time ``t`` [s] with the command ``(mode, cmd)`` through vilma's actuators; ``z`` (planar state and
    actuator outputs) is updated in place and the sensors' sample ticks are recorded, with what only the 3D plant has
    in ``out_3d``; with ``poses``, the body poses are made for the end (cameras and the laser see them; the stepping
    does not read them). Returns the number of rows written."""
    quat, mat = np.empty(4), np.empty(9)
    qpos, qvel = car[QPOS], car[QVEL]
    u = z[NX:]  # the actuators advance in place, as vilma.vehicle.integrate.advance's
    body_pose(qpos, quat, mat)
    x = planar_state(qpos, qvel, mat)
    j = 0
    for i in range(1, n + 1):
        actuate(mode, cmd, x, u, consts, dt)
        t = block(ptrs, car, traffic, mat, u[0], u[1], u[2], nstep, t)
        body_pose(qpos, quat, mat)
        x = planar_state(qpos, qvel, mat)
        if sampled(tick + i, periods):
            for k in range(NX):
                out_z[j, k] = x[k]
            out_z[j, NX:] = u
            _record(car, mat, x, out_dx, out_3d, j)
            out_tick[j] = tick + i
            j += 1
    z[:NX] = x
    if poses:
        _mj_kinematics(ptrs[0], ptrs[1])
    return j
