"""Extended Kalman filter for the planar pose: GPS position, IMU yaw rate and acceleration, wheel speeds.

State ``s = [x, y, yaw, v, b]``: position of the centre of mass [m] (ENU), yaw [rad], signed forward
speed [m/s] and the gyro's yaw-rate bias [rad/s].

Motion: a kinematic single track whose rear axle rolls without side slip, so the centre of mass also
moves sideways at ``vy = lr w`` (``lr``: centre of mass to rear axle), driven by the IMU's yaw rate
``w = wz - b`` and forward specific force ``ax`` (IMU at the centre of mass, where ``ax = v' - w vy``)::

    x' = v cos(yaw) - vy sin(yaw)    y' = v sin(yaw) + vy cos(yaw)
    yaw' = w                         v' = ax + lr w^2                 b' = 0 (random walk)

integrated from one IMU sample to the next with the mean of the two samples and the midpoint heading.
Measurements, each a scalar Joseph-form update:

- wheel speeds (rear wheels, not steered): ``v = R (rl + rr) / 2`` and ``wz - b = R (rr - rl) / track``;
- GPS: the antenna at ``[x, y] + Rot(yaw) o`` (lever arm ``o``), gated by the chi-square distance of
  its innovation; after ``gps_max_rejections`` fixes rejected in a row the position restarts from the fix;
- optionally the IMU's yaw (``imu_yaw_noise``).

Initialisation: heading is unobservable at rest, so it comes from the IMU's orientation (the simulated
IMU reports an absolute yaw with small noise, as an AHRS does), position from the first GPS fix after
an IMU sample, speed 0. Until then :meth:`Ekf.update` returns None; without an IMU it never starts.

The filter runs compiled (numba): one call of :func:`fuse` per :meth:`Ekf.update` merges the batches by stamp;
the scenario runner's compiled loop calls it too, on the same arrays (:meth:`Ekf.kernel_args`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from vilma.core.geometry import wrap
from vilma.core.messages import PoseEstimate
from vilma.sensors import Readings
from vilma.sensors.gps import GpsParams
from vilma.sensors.imu import ImuParams
from vilma.sensors.wheel_speed import WheelSpeedParams
from vilma.vehicle.params import VehicleParams

X, Y, YAW, V, BIAS = range(5)
"""Indices of the state vector."""
N = 5
"""State size."""

_WZ, _AX, _IMU_YAW = range(3)
"""Slots of the latest IMU sample (NaN before the first)."""
_T, _READY, _REJECTS = range(3)
"""Slots of the integer memory: stamp of the state [ns], initialised (0/1), GPS fixes rejected in a row."""

_NO_STAMP = np.iinfo(np.int64).max


@dataclass(frozen=True, slots=True, kw_only=True)
class EkfParams:
    """Noises, car geometry and gating of :class:`Ekf`; noise defaults are the sensors' defaults.

    Build one for a car with :meth:`for_vehicle`.
    """

    wheel_radius: float
    """Rolling radius [m]."""
    track: float
    """Distance between the rear wheels [m]."""
    cg_to_rear: float
    """Centre of mass to rear axle [m]."""
    gyro_noise: float = ImuParams().gyro_noise
    """White noise of each yaw-rate sample [rad/s]."""
    accel_noise: float = ImuParams().accel_noise
    """White noise of each acceleration sample [m/s^2]."""
    gyro_bias: float = ImuParams().gyro_bias
    """Initial standard deviation of the gyro bias [rad/s]."""
    gyro_bias_drift: float = ImuParams().gyro_bias * math.sqrt(2.0 / ImuParams().bias_tau)
    """Random-walk intensity of the gyro bias [rad/s/sqrt(s)] (a Gauss-Markov bias: sigma sqrt(2 / tau))."""
    speed_drift: float = 0.2
    """Random-walk intensity of the speed for unmodelled acceleration (accelerometer bias, slip) [m/s/sqrt(s)]."""
    sideslip_drift: float = 0.005
    """Random-walk intensity of the side-slip angle the model leaves out (tyre slip) [rad/sqrt(s)];
    times the speed, the position's [m/sqrt(s)]. The rear tyres' slip angle at 2 m/s^2 lateral is about
    0.01 rad on the ``vilma`` car and changes over seconds."""
    wheel_noise: float = WheelSpeedParams().noise
    """White noise of each wheel speed [rad/s]."""
    gps_noise: float = GpsParams().horizontal_noise
    """White noise of the GPS east and north [m]."""
    gps_offset: tuple[float, float] = GpsParams().offset[:2]
    """Horizontal antenna position from the centre of mass, body frame (x forward, y left) [m]."""
    gps_gate: float = 13.8
    """Chi-square bound on a fix's innovation (2 dof; 13.8 rejects 0.1 % of good fixes) [-]."""
    gps_max_rejections: int = 10
    """After this many fixes rejected in a row, restart the position from the fix [-]."""
    imu_yaw_noise: float | None = None
    """Fuse the IMU's yaw with this standard deviation [rad]; None: use it only to start."""
    initial_yaw_std: float = ImuParams().orientation_noise
    """Standard deviation of the IMU yaw the heading starts from [rad]."""
    initial_speed_std: float = 1.0
    """Standard deviation of the speed 0 the filter starts from [m/s]."""

    def __post_init__(self) -> None:
        for name in ("wheel_radius", "track", "gps_noise", "gps_gate", "initial_yaw_std", "initial_speed_std"):
            if not getattr(self, name) > 0:
                raise ValueError(f"EkfParams.{name} must be > 0, got {getattr(self, name)!r}")
        if self.imu_yaw_noise is not None and not self.imu_yaw_noise > 0:
            raise ValueError(f"EkfParams.imu_yaw_noise must be > 0 or None, got {self.imu_yaw_noise!r}")
        if self.gps_max_rejections < 1:
            raise ValueError(f"EkfParams.gps_max_rejections must be >= 1, got {self.gps_max_rejections!r}")

    @classmethod
    def for_vehicle(cls, vehicle: VehicleParams, **kw) -> EkfParams:
        """Parameters for ``vehicle``'s wheels and geometry; ``kw`` overrides any field."""
        return cls(**{"wheel_radius": vehicle.wheel_radius, "track": vehicle.track, "cg_to_rear": vehicle.cg_to_rear,
                      **kw})


class _Consts(NamedTuple):
    """:class:`EkfParams` as the compiled code reads them (variances, 0 for an unused measurement)."""

    lr: float
    radius: float
    track: float
    q_gyro: float
    q_accel: float
    q_bias: float
    q_speed: float
    q_slip: float
    r_speed: float
    r_yaw_rate: float
    r_gps: float
    ox: float
    oy: float
    gate: float
    max_rejections: int
    r_imu_yaw: float
    p0_yaw: float
    p0_speed: float
    p0_bias: float


def _consts(p: EkfParams) -> _Consts:
    r_wheel = (p.wheel_radius * p.wheel_noise) ** 2
    return _Consts(
        lr=p.cg_to_rear, radius=p.wheel_radius, track=p.track, q_gyro=p.gyro_noise**2, q_accel=p.accel_noise**2,
        q_bias=p.gyro_bias_drift**2, q_speed=p.speed_drift**2, q_slip=p.sideslip_drift**2,
        r_speed=r_wheel / 2.0, r_yaw_rate=2.0 * r_wheel / p.track**2 + p.gyro_noise**2, r_gps=p.gps_noise**2,
        ox=p.gps_offset[0], oy=p.gps_offset[1], gate=p.gps_gate, max_rejections=p.gps_max_rejections,
        r_imu_yaw=0.0 if p.imu_yaw_noise is None else p.imu_yaw_noise**2, p0_yaw=p.initial_yaw_std**2,
        p0_speed=p.initial_speed_std**2, p0_bias=p.gyro_bias**2)


@njit(cache=True)
def _mv(A, v):
    """``A @ v`` for a small matrix, in plain loops (numba compiles ``@`` and ``np.outer`` slowly)."""
    out = np.zeros(A.shape[0])
    for i in range(A.shape[0]):
        for j in range(A.shape[1]):
            out[i] += A[i, j] * v[j]
    return out


@njit(cache=True)
def _sandwich(A, P):
    """``A @ P @ A.T`` for small square matrices, in plain loops."""
    n = A.shape[0]
    AP = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            for k in range(n):
                AP[i, j] += A[i, k] * P[k, j]
    out = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            for k in range(n):
                out[i, j] += AP[i, k] * A[j, k]
    return out


@njit(cache=True)
def _predict(s, P, dt, wz, ax, c):
    """Propagate state and covariance by ``dt`` [s] with yaw rate ``wz`` [rad/s] and acceleration ``ax``."""
    w = wz - s[BIAS]
    vy = c.lr * w
    mid = s[YAW] + 0.5 * w * dt
    cm, sm = math.cos(mid), math.sin(mid)
    v = s[V]
    dx = (v * cm - vy * sm) * dt
    dy = (v * sm + vy * cm) * dt
    F = np.eye(N)
    F[X, YAW], F[X, V], F[X, BIAS] = -dy, cm * dt, (c.lr * sm + 0.5 * dy) * dt
    F[Y, YAW], F[Y, V], F[Y, BIAS] = dx, sm * dt, -(c.lr * cm + 0.5 * dx) * dt
    F[YAW, BIAS] = -dt
    F[V, BIAS] = -2.0 * c.lr * w * dt
    s[X] += dx
    s[Y] += dy
    s[YAW] = wrap(s[YAW] + w * dt)
    s[V] += (ax + c.lr * w * w) * dt
    P[:] = _sandwich(F, P)
    q_pos = c.q_slip * v * v * dt
    P[X, X] += q_pos
    P[Y, Y] += q_pos
    P[YAW, YAW] += c.q_gyro * dt * dt
    P[V, V] += c.q_accel * dt * dt + c.q_speed * dt
    P[BIAS, BIAS] += c.q_bias * dt


@njit(cache=True)
def _correct(s, P, h, innovation, r):
    """Scalar measurement with Jacobian row ``h`` (N,), ``innovation`` and noise variance ``r``: Joseph form."""
    ph = _mv(P, h)
    k = ph / (np.sum(h * ph) + r)
    s += k * innovation
    s[YAW] = wrap(s[YAW])
    A = np.eye(N)
    for i in range(N):
        for j in range(N):
            A[i, j] -= k[i] * h[j]
    P[:] = _sandwich(A, P)
    for i in range(N):
        for j in range(N):
            P[i, j] += r * k[i] * k[j]
    P[:] = 0.5 * (P + P.T)


@njit(cache=True)
def _antenna(s, c):
    """GPS antenna position [m] and its Jacobian rows for x and y."""
    cy, sy = math.cos(s[YAW]), math.sin(s[YAW])
    hx, hy = np.zeros(N), np.zeros(N)
    hx[X], hx[YAW] = 1.0, -c.ox * sy - c.oy * cy
    hy[Y], hy[YAW] = 1.0, c.ox * cy - c.oy * sy
    return s[X] + c.ox * cy - c.oy * sy, s[Y] + c.ox * sy + c.oy * cy, hx, hy


@njit(cache=True)
def _start(s, P, gx, gy, yaw, c):
    """Position from a fix at ``(gx, gy)`` [m] given heading ``yaw`` [rad] (also used to restart it)."""
    s[YAW] = yaw
    s[X], s[Y] = gx - c.ox * math.cos(yaw) + c.oy * math.sin(yaw), gy - c.ox * math.sin(yaw) - c.oy * math.cos(yaw)
    P[X, :] = 0.0
    P[:, X] = 0.0
    P[Y, :] = 0.0
    P[:, Y] = 0.0
    P[X, X] = P[Y, Y] = c.r_gps


@njit(cache=True)
def _gps(s, P, mem, gx, gy, c):
    """GPS fix: chi-square gate on the 2-D innovation, then x and y as two scalar updates."""
    ax_, ay_, hx, hy = _antenna(s, c)
    ex, ey = gx - ax_, gy - ay_
    phx, phy = _mv(P, hx), _mv(P, hy)
    sxx, syy, sxy = np.sum(hx * phx) + c.r_gps, np.sum(hy * phy) + c.r_gps, np.sum(hx * phy)
    d2 = (syy * ex * ex - 2.0 * sxy * ex * ey + sxx * ey * ey) / (sxx * syy - sxy * sxy)
    if d2 > c.gate:
        mem[_REJECTS] += 1
        if mem[_REJECTS] >= c.max_rejections:
            mem[_REJECTS] = 0
            _start(s, P, gx, gy, s[YAW], c)
        return
    mem[_REJECTS] = 0
    _correct(s, P, hx, ex, c.r_gps)
    ax_, ay_, hx, hy = _antenna(s, c)
    _correct(s, P, hy, gy - ay_, c.r_gps)


@njit(cache=True)
def _yaw(qx, qy, qz, qw):
    """Yaw [rad] of a quaternion (ZYX)."""
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


@njit(cache=True)
def _advance(s, P, mem, t, wz, ax, c):
    """Predict to stamp ``t`` [ns] with inputs ``wz``, ``ax`` held since the state's stamp."""
    dt = (t - mem[_T]) * 1e-9
    if dt > 0.0:
        _predict(s, P, dt, wz, ax, c)
        mem[_T] = t


@njit(cache=True)
def fuse(s, P, mem, imu_last, imu_t, imu, wheel_t, wheel, gps_t, gps, c):
    """Process the readings of one batch in stamp order (IMU, then wheels, then GPS at equal stamps).

    Advances state ``s``, covariance ``P``, memory ``mem`` and the latest IMU sample ``imu_last`` in place
    (:meth:`Ekf.kernel_args`); ``imu_t``, ``wheel_t``, ``gps_t`` are stamps [ns], each (n,) ascending;
    ``imu`` (n, 10), ``wheel`` (n, 4) and ``gps`` (n, 6) are rows of :class:`~vilma.core.messages.Imu`,
    :class:`~vilma.core.messages.WheelSpeeds` and :class:`~vilma.core.messages.GpsFix` values.
    """
    i = j = k = 0
    while i < len(imu_t) or j < len(wheel_t) or k < len(gps_t):
        ti = imu_t[i] if i < len(imu_t) else _NO_STAMP
        tj = wheel_t[j] if j < len(wheel_t) else _NO_STAMP
        tk = gps_t[k] if k < len(gps_t) else _NO_STAMP
        if ti <= tj and ti <= tk:
            wz, ax, yaw = imu[i, 5], imu[i, 0], _yaw(imu[i, 6], imu[i, 7], imu[i, 8], imu[i, 9])
            if mem[_READY]:
                _advance(s, P, mem, ti, 0.5 * (wz + imu_last[_WZ]), 0.5 * (ax + imu_last[_AX]), c)
                if c.r_imu_yaw > 0.0:
                    h = np.zeros(N)
                    h[YAW] = 1.0
                    _correct(s, P, h, wrap(yaw - s[YAW]), c.r_imu_yaw)
            imu_last[_WZ], imu_last[_AX], imu_last[_IMU_YAW] = wz, ax, yaw
            i += 1
        elif tj <= tk:
            if mem[_READY]:
                _advance(s, P, mem, tj, imu_last[_WZ], imu_last[_AX], c)
                rl, rr = wheel[j, 2], wheel[j, 3]
                h = np.zeros(N)
                h[V] = 1.0
                _correct(s, P, h, 0.5 * c.radius * (rl + rr) - s[V], c.r_speed)
                h[V], h[BIAS] = 0.0, -1.0
                _correct(s, P, h, c.radius * (rr - rl) / c.track - (imu_last[_WZ] - s[BIAS]), c.r_yaw_rate)
            j += 1
        else:
            if mem[_READY]:
                _advance(s, P, mem, tk, imu_last[_WZ], imu_last[_AX], c)
                _gps(s, P, mem, gps[k, 3], gps[k, 4], c)
            elif not math.isnan(imu_last[_IMU_YAW]):
                s[:] = 0.0
                P[:] = 0.0
                P[YAW, YAW], P[V, V], P[BIAS, BIAS] = c.p0_yaw, c.p0_speed, c.p0_bias
                _start(s, P, gps[k, 3], gps[k, 4], imu_last[_IMU_YAW], c)
                mem[_T], mem[_READY] = tk, 1
            k += 1


_NO_READINGS = np.empty(0, dtype=np.int64)


def _rows(readings: dict[str, Readings], name: str, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Stamps (n,) and values (n, width) of sensor ``name``, empty without readings (one compiled signature)."""
    r = readings.get(name)
    if r is None or not len(r):
        return _NO_READINGS, np.empty((0, width))
    return np.ascontiguousarray(r.stamp_ns, dtype=np.int64), np.ascontiguousarray(r.values, dtype=np.float64)


class Ekf:
    """The extended Kalman filter of this module: a :class:`~vilma.localization.base.PoseEstimator`.

    Reads the ``imu``, ``wheel_speed`` and ``gps`` readings; ignores the rest.
    """

    def __init__(self, params: EkfParams) -> None:
        self.params = params
        self._c = _consts(params)
        self.reset()

    def reset(self) -> None:
        """Forget everything: wait again for an IMU sample and a GPS fix."""
        self._s = np.zeros(N)
        self._P = np.zeros((N, N))
        self._mem = np.zeros(3, dtype=np.int64)
        self._imu = np.full(3, np.nan)
        self.estimate: PoseEstimate | None = None

    @property
    def state(self) -> np.ndarray:
        """A copy of the state ``[x, y, yaw, v, b]`` (units in the module docstring), shape (5,)."""
        return self._s.copy()

    @property
    def covariance(self) -> np.ndarray:
        """A copy of the state covariance, shape (5, 5)."""
        return self._P.copy()

    def update(self, readings: dict[str, Readings]) -> PoseEstimate | None:
        """Fuse one batch of readings by sensor name; the estimate at the newest stamp, or None before the start."""
        fuse(self._s, self._P, self._mem, self._imu, *_rows(readings, "imu", 10),
             *_rows(readings, "wheel_speed", 4), *_rows(readings, "gps", 6), self._c)
        return self.refresh()

    def kernel_args(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, _Consts]:
        """``(s, P, mem, imu_last, c)`` of :func:`fuse`: the live arrays, for compiled code that fuses in place."""
        return self._s, self._P, self._mem, self._imu, self._c

    def refresh(self) -> PoseEstimate | None:
        """The estimate from the arrays as they are now (after :func:`fuse` advanced them), None before the start."""
        if self._mem[_READY]:
            s, P = self._s.tolist(), self._P
            self.estimate = PoseEstimate(int(self._mem[_T]), s[X], s[Y], s[YAW], s[V], float(self._imu[_WZ]) - s[BIAS],
                                         math.sqrt(P[X, X]), math.sqrt(P[Y, Y]), math.sqrt(P[YAW, YAW]))
        return self.estimate


@njit(cache=True)
def pose_of(s, mem, imu_last):
    """``(started, x, y, yaw, speed, yaw rate)`` of the arrays of :func:`fuse`, as :meth:`Ekf.refresh` reads them."""
    return mem[_READY] != 0, s[X], s[Y], s[YAW], s[V], imu_last[_WZ] - s[BIAS]
