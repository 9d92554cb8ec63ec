"""The sensors of a suite, measured together in one compiled call a chunk (on a planar plant or the 3D one).

A chunk of 20 ms holds one or two samples of each sensor: measured one by one in Python, the calls cost far
more than the numbers. Here one compiled call fills every sensor's readings into preallocated blocks, and the
readings handed out are views of them. A block is filled once and never rewritten (a full one is replaced, not
reused), so readings stay valid however long they are kept.

The noise of each sensor is drawn ahead from its own generator in blocks: the same numbers in the same order as
its :meth:`measure` takes them (a generator's draws do not depend on how they are split), so readings are
bit-identical to the sensors' own, however the run is chunked.

The compiled code here and the sensors' kernels use numpy's error model: their divisors (a period that is not 0,
the wheels' radius, the track) cannot be zero, and numba's check of each division for zero cost a tenth of it.
"""

from __future__ import annotations

import copy

import numpy as np
from numba import njit

from vilma.sensors.actuator_state import ActuatorStateSensor
from vilma.sensors.base import NO_3D, Readings, Sensor
from vilma.sensors.gps import GpsSensor
from vilma.sensors.gps import measure_into as gps_into
from vilma.sensors.imu import ImuSensor, ideal
from vilma.sensors.imu import measure_into as imu_into
from vilma.sensors.odometry import OdometrySensor, integrate_into
from vilma.sensors.pose import PoseSensor
from vilma.sensors.pose import measure_into as pose_into
from vilma.sensors.velocity import NORMALS as VELOCITY_NORMALS
from vilma.sensors.velocity import NORMALS_3D as VELOCITY_NORMALS_3D
from vilma.sensors.velocity import VelocitySensor
from vilma.sensors.velocity import measure_into as velocity_into
from vilma.sensors.wheel_speed import WheelSpeedSensor, wheel_speeds
from vilma.sensors.wheel_speed import measure_into as wheel_into
from vilma.vehicle.state import BRAKE, STEER

KINDS = (PoseSensor, VelocitySensor, GpsSensor, ImuSensor, WheelSpeedSensor, OdometrySensor, ActuatorStateSensor)
"""The sensors a bank measures, in the order of its slots."""
POSE, VELOCITY, GPS, IMU, WHEEL_SPEED, ODOMETRY, ACTUATORS = range(len(KINDS))
NORMALS = (3, VELOCITY_NORMALS, 6, 13, 4, 2, 0)
"""Standard normals each kind draws a sample on a planar plant."""
NORMALS_3D = (3, VELOCITY_NORMALS_3D, 6, 13, 4, 2, 0)
"""Standard normals each kind draws a sample on the 3D plant (the velocity sensor's roll and pitch rates too)."""
WIDTHS = (6, 9, 6, 10, 4, 5, 3)
"""Values of each kind's reading."""
MAX_NORMALS, MAX_WIDTH = max(NORMALS), max(WIDTHS)
ENDLESS = 2**62
"""The noise rows a sensor without noise holds."""
BLOCK = 512
"""Samples a block of readings or of noise holds (more if one chunk needs more)."""
FIRST_AHEAD = 8
"""Samples of noise drawn ahead at first: the draws double from there to :data:`BLOCK`, so a run that measures
little (a compiled loop whose readings nobody takes measures only its first period) draws little."""
VEC, AXES = len(KINDS), len(KINDS) + 9
"""Rows of a bank's ``par`` after each slot's scalars: the vectors and states of :meth:`SensorBank.reset` (nine
rows from :data:`VEC`), the GPS's ENU axes (row :data:`AXES`, flattened)."""
PERIOD, COUNT, USED, HELD, FILLED, DRAWS = range(6)
"""Rows of a bank's book: each slot's sample period [ticks] (0: no sensor), samples in the chunk, noise rows used
and held, block rows filled, standard normals a sample (:data:`NORMALS` or :data:`NORMALS_3D`)."""


@njit(cache=True, error_model="numpy")
def counts_fit(t0, n, book, noise, outs):
    """Set each slot's count to its samples in the steps ``t0 + 1 .. t0 + n``; whether its noise and block hold them."""
    fit = True
    for s in range(book.shape[1]):
        p = book[PERIOD, s]
        c = (t0 + n) // p - t0 // p if p else 0
        book[COUNT, s] = c
        if book[USED, s] + c > book[HELD, s] or book[FILLED, s] + c > outs.shape[1] // MAX_WIDTH:
            fit = False
    return fit


@njit(cache=True, error_model="numpy")
def as_rows(flat, first, n, width):
    """Rows ``first .. first + n`` of the C-contiguous 1-d array ``flat`` seen as rows of ``width``: a reshape without
    numba's call to its C helper (12 ns, and :func:`measure_all` cuts 15 such views a frame)."""
    return np.lib.stride_tricks.as_strided(flat[first * width:(first + n) * width], shape=(n, width),
                                           strides=(width * flat.itemsize, flat.itemsize))


@njit(cache=True, error_model="numpy")
def measure_all(t0, ticks, z, dx, extra, step_ns, book, noise, outs, stamps, par):
    """Fill each slot's next readings (as many as :func:`counts_fit` counted) from the plant recorded at ``ticks``
    (``z``, ``dx``, and the 3D plant's ``extra``: :data:`~vilma.sensors.base.NO_3D` on a planar plant).

    Slot ``s`` takes its normals (rows of ``book[DRAWS, s]``) from ``noise[s]`` and writes its readings (rows of
    ``WIDTHS[s]``) into ``outs[s]`` and ``stamps[s]`` from the rows its book says; ``par[s]`` holds its scalars,
    and ``par`` from row :data:`VEC` the vectors and states of :meth:`SensorBank.reset` (one array: numba unboxes
    each array a call takes for some 40 ns).
    """
    axes = as_rows(par[AXES], 0, 3, 3)
    rows = np.empty(ticks.shape[0], dtype=np.int64)  # this slot's rows of the records
    for s in range(book.shape[1]):
        c, p, u, a, d, q = book[COUNT, s], book[PERIOD, s], book[USED, s], book[FILLED, s], book[DRAWS, s], par[s]
        if c == 0:
            continue
        first, j = (t0 // p + 1) * p, 0
        for i in range(ticks.shape[0]):
            if ticks[i] % p == 0:
                rows[j], j = i, j + 1
        r = rows[:c]
        for k in range(c):
            stamps[s, a + k] = (first + k * p) * step_ns
        w, width = as_rows(noise[s], u, c, d), WIDTHS[s]
        out = as_rows(outs[s], a, c, width)
        if s == POSE:
            pose_into(r, z, extra, w, q[0], q[1], out)
        elif s == VELOCITY:
            velocity_into(r, z, extra, w, q[0], q[1], out)
        elif s == GPS:
            gps_into(r, z, extra, w, par[VEC, :3], par[VEC + 1, :3], par[VEC + 2, :3], q[0], q[1], par[VEC + 3, :3],
                     axes, out)
        elif s == IMU:
            imu_into(ideal(r, z, dx, extra, par[VEC + 4, :3]), w, q[0], q[1], q[2], par[VEC + 5, :3], par[VEC + 6, :3],
                     q[3], q[4], q[5], out)
        elif s == WHEEL_SPEED:
            wheel_into(r, z, w, q[0], q[1], q[2], q[3], out)
        elif s == ODOMETRY:
            rear = wheel_speeds(r, z, q[1], q[2], q[3])[:, 2:]
            integrate_into(rear, w, q[0], par[VEC + 7, :2], q[3], q[2], q[4], par[VEC + 8, :5], out)
        else:
            for k in range(c):
                for i in range(BRAKE - STEER + 1):  # by element: a slice copy compiles its shape check's message
                    out[k, i] = z[r[k], STEER + i]
        book[USED, s], book[FILLED, s] = u + c, a + c


class SensorBank:
    """The readings of ``sensors`` (at most one of each of :data:`KINDS`; sample ``periods`` in ticks, in the same
    order) from a plant's records (the 3D plant's if ``plant3d``), in one compiled call.

    Its arrays are what compiled code takes: ``book`` (:data:`PERIOD` ...), ``noise``, ``outs``, ``stamps`` and ``par``
    (see :func:`measure_all`).
    """

    def __init__(self, sensors: list[Sensor], periods: np.ndarray, plant3d: bool = False) -> None:
        self._sensors, self._slots = sensors, [KINDS.index(type(s)) for s in sensors]
        self._by_slot: list = [None] * len(KINDS)
        self._normals = NORMALS_3D if plant3d else NORMALS
        self.book = np.zeros((DRAWS + 1, len(KINDS)), dtype=np.int64)
        self.book[DRAWS] = self._normals
        self._counts_filled = self.book[COUNT::FILLED - COUNT]  # a view of the two rows readings() takes
        for slot, sensor, period in zip(self._slots, sensors, periods.tolist(), strict=True):
            self._by_slot[slot], self.book[PERIOD, slot] = sensor, period
        self.par = np.zeros((AXES + 1, 9))
        self._new_blocks(FIRST_AHEAD)

    def reset(self) -> None:
        """Take the sensors' generators and states anew (after their :meth:`~vilma.sensors.base.Sensor.reset`); the
        bank's ``vec`` rows become the sensors' drifting states, so both advance together."""
        self.noise, self.book[USED], self._ahead = np.zeros((len(KINDS), 0)), 0, FIRST_AHEAD
        self.book[HELD] = [0 if d else ENDLESS for d in self._normals]
        pose, velocity, gps, imu, wheel, odometry, _ = self._by_slot
        q, v = self.par, self.par[VEC:]
        if pose is not None:
            q[POSE, :2] = pose.params.position_noise, pose.params.yaw_noise
        if velocity is not None:
            q[VELOCITY, :2] = velocity.params.linear_noise, velocity.params.angular_noise
        q[AXES] = (gps.frame.axes if gps is not None else np.eye(3)).ravel()
        if gps is not None:
            q[GPS, :2] = gps.bias.phi, gps.bias.step_sigma
            h, up = gps.params.horizontal_noise, gps.params.vertical_noise
            v[0, :3], v[1, :3], v[3, :3] = gps.params.offset, (h, h, up), gps.frame.ecef0
            v[2, :3], gps.bias.b = gps.bias.b, v[2, :3]
        if imu is not None:
            p, a, w = imu.params, imu.accel_bias, imu.gyro_bias
            q[IMU, :6] = p.accel_noise, p.gyro_noise, p.orientation_noise, a.phi, a.step_sigma, w.step_sigma
            v[4, :3] = p.offset
            v[5, :3], v[6, :3], a.b, w.b = a.b, w.b, v[5, :3], v[6, :3]
        for sensor, slot in ((wheel, WHEEL_SPEED), (odometry, ODOMETRY)):
            if sensor is not None:
                sigma = sensor.params.noise if slot == WHEEL_SPEED else sensor.params.wheel_noise
                q[slot, :4] = sigma, sensor.vehicle.cg_to_front, sensor.vehicle.track, sensor.vehicle.wheel_radius
        if odometry is not None:
            q[ODOMETRY, 4] = odometry.period
            v[7, :2], v[8, :5], odometry.scale, odometry.state = odometry.scale, odometry.state, v[7, :2], v[8, :5]

    @property
    def arrays(self) -> tuple[np.ndarray, ...]:
        """``book, noise, outs, stamps, par``, as :func:`measure_all` takes them (:meth:`make_room` may replace
        ``noise``, ``outs`` and ``stamps``)."""
        return self.book, self.noise, self.outs, self.stamps, self.par

    def measure(self, t0: int, n: int, ticks: np.ndarray, z: np.ndarray, dx: np.ndarray, step_ns: int,
                extra: np.ndarray = NO_3D) -> dict[str, Readings]:
        """The readings of the steps ``t0 + 1 .. t0 + n`` from the plant ``z``, ``dx`` (and the 3D plant's ``extra``)
        recorded at ``ticks`` (:func:`~vilma.vehicle.integrate.advance`), by sensor name (see :meth:`readings`)."""
        if not counts_fit(t0, n, self.book, self.noise, self.outs):
            self.make_room()
        measure_all(t0, ticks, z, dx, extra, step_ns, *self.arrays)
        return self.readings()

    def readings(self) -> dict[str, Readings]:
        """The readings :func:`measure_all` made last, by sensor name; sensors with none are left out."""
        counts, filled = self._counts_filled.tolist()
        out = {}
        for slot, name, message, stamps, values in self._blocks:
            if c := counts[slot]:
                b = filled[slot]
                out[name] = Readings(name, message, stamps, values, b - c, b)
        return out

    def normals_ahead(self, sensor: Sensor, count: int) -> np.ndarray:
        """The standard normals ``sensor`` takes for its next ``count`` samples, (count, normals a sample), left for
        it to take: those drawn ahead, then the next ones of a copy of its generator."""
        slot = KINDS.index(type(sensor))
        d, used, held = self._normals[slot], int(self.book[USED, slot]), int(self.book[HELD, slot])
        ahead = self.noise[slot, used * d:min(held, used + count) * d]
        more = copy.deepcopy(sensor.rng).standard_normal(count * d - len(ahead))
        return np.concatenate([ahead, more]).reshape(count, d)

    def make_room(self) -> None:
        """Top up every sensor's noise to ``need`` samples ahead and start new blocks, ``need`` at least the samples
        :func:`counts_fit` counted. Every stream is topped up, not only those short of noise, so the streams run
        short together, when the fastest sensor fills its block: one call a block (refilled one by one, they ran
        short apart, and 20 ms frames made room every 160 frames instead of 256)."""
        b = self.book
        need = max(self._ahead, *b[COUNT].tolist())
        self._ahead = min(2 * self._ahead, BLOCK)
        kept, low = [], []  # per slot: normals not yet used, whether to draw up to ``need`` samples
        for slot, (u, held) in enumerate(zip(b[USED].tolist(), b[HELD].tolist(), strict=True)):
            d = self._normals[slot]
            kept.append((u * d, held * d) if d else (0, 0))
            low.append(bool(d) and self._by_slot[slot] is not None and held - u < need)
        sizes = [need * d if t else hi - lo for (lo, hi), t, d in zip(kept, low, self._normals, strict=True)]
        rows = max(BLOCK, *(n // max(d, 1) for n, d in zip(sizes, self._normals, strict=True)))
        old = self.noise
        if old.shape[1] < rows * MAX_NORMALS:  # else the rows are reused: the unused normals move to the front
            self.noise = np.empty((len(KINDS), rows * MAX_NORMALS))
        for slot, ((lo, hi), t) in enumerate(zip(kept, low, strict=True)):
            self.noise[slot, :hi - lo] = old[slot, lo:hi]
            if t:  # drawn in place: the same numbers as drawn apart
                self._by_slot[slot].rng.standard_normal(out=self.noise[slot, hi - lo:sizes[slot]])
            b[HELD, slot] = sizes[slot] // self._normals[slot] if self._normals[slot] else ENDLESS
        b[USED] = 0
        if (b[FILLED] + b[COUNT] > self.outs.shape[1] // MAX_WIDTH).any():
            self._new_blocks(need)

    def _new_blocks(self, rows: int) -> None:
        self.outs, self.stamps = np.zeros((len(KINDS), rows * max(WIDTHS))), np.zeros((len(KINDS), rows), np.int64)
        self._blocks = [(s, sensor.name, sensor.message, self.stamps[s],
                         self.outs[s, :rows * WIDTHS[s]].reshape(rows, -1))
                        for s, sensor in zip(self._slots, self._sensors, strict=True)]
        self.book[FILLED] = 0
