"""Fixed-step simulator of one car: plant, actuators, sensors and a command watchdog.

Time is the integer tick of :class:`~vilma.core.clock.Clock`. Physics runs
in compiled chunks between events (a delayed command taking effect, the
watchdog firing); sensors sample the plant at whole multiples of the step
and are measured in vectorised batches. Nothing here reads the wall clock,
so a run is a pure function of configuration, seed and commands: the same
inputs give bit-identical states and readings, however the run is chunked.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections import deque
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from vilma.core.arrays import table
from vilma.core.clock import Clock, seconds_to_ns
from vilma.core.closing import Closeable
from vilma.core.extras import require
from vilma.core.messages import ActuatorCommand, Message, SimStatus
from vilma.core.ratelimit import WarningThrottle
from vilma.plant3d.capture import WorldSensor
from vilma.sensors import Readings, Samples, Sensor, build_sensors
from vilma.sensors.bank import SensorBank
from vilma.sensors.base import rows_of, sensor_rng
from vilma.sim.config import MUJOCO, SimConfig
from vilma.sim.frame import ARRAYS, CMD, direct, run_frame
from vilma.vehicle import models
from vilma.vehicle.actuators import MODE_IDS, STOP, command_limits, validate_command
from vilma.vehicle.integrate import INTEGRATORS, constrain_start, empty_records
from vilma.vehicle.params import plant_consts
from vilma.vehicle.state import N3, NZ, VX, YAW, VehicleState, X, Y
from vilma.world.idm import IdmArrays

log = logging.getLogger(__name__)

NO_PERIODS = np.zeros(0, dtype=np.int64)
"""The sample periods of a kernel whose sensors skip its steps (:meth:`Simulator.kernel_start`)."""


class PlantKernel(NamedTuple):
    """What compiled code advancing a :class:`Simulator` works on (:meth:`Simulator.advance_compiled`)."""

    model: int
    integrator: int
    z: np.ndarray
    """The live plant vector, advanced in place."""
    consts: tuple
    """The plant's constants (:func:`~vilma.vehicle.params.plant_consts`)."""
    step: float
    """Physics step [s]."""
    step_ns: int
    tick: int
    """The tick it starts from."""
    periods: np.ndarray
    """The sensors' sample periods [ticks]."""
    records: tuple[np.ndarray, np.ndarray, np.ndarray]
    """``(out_z, out_dx, out_tick)`` for the plant at the sensors' sample ticks, room for a sample a step."""
    mode: np.ndarray
    """``[longitudinal mode id]`` of the command in force."""
    cmd: np.ndarray
    """``[steer, drive, brake, velocity limit]`` in force."""
    limits: np.ndarray
    """The car's command limits (:func:`~vilma.vehicle.actuators.command_limits`)."""
    traffic: IdmArrays | None
    """The reactive traffic's arrays (:attr:`SimConfig.reactive`; None without), to step at
    each of its period ends (:func:`~vilma.world.idm.idm_step`)."""


class KernelResult(NamedTuple):
    """What compiled code did to a :class:`Simulator`: steps advanced, samples recorded, and the tick it last set
    an autonomous command at (None: it set none)."""

    ticks: int
    records: int
    commanded_tick: int | None


class Simulator(Closeable):
    """One car on flat ground.

    Use :meth:`command` to set actuator commands and :meth:`run_for` /
    :meth:`step` to advance; both return the sensor readings made meanwhile,
    by sensor name. It starts at ``initial`` (default: the configured one), as after :meth:`reset`.
    """

    def __init__(self, config: SimConfig | None = None, initial: VehicleState | None = None) -> None:
        self.config = c = config or SimConfig()
        self.clock = Clock(seconds_to_ns(c.step))
        self._consts = plant_consts(c.vehicle)
        # the plant vector, the command in force and the constants, end to end: one array for compiled code
        self._plant = np.concatenate([np.zeros(NZ + CMD), self._consts])  # to take (sim/frame.py)
        self._z, self._cmd = self._plant[:NZ], self._plant[NZ:NZ + CMD]  # views, written in place
        self._limits = command_limits(c.vehicle)  # for compiled code, made once
        self._limit_rows = self._limits.tolist()  # for validate_command
        self._plant3d = None
        self._world_sensors: list[WorldSensor] = []
        if c.model == MUJOCO:
            require("3d", "the 3D plant (plant: mujoco)")
            from vilma.plant3d.camera import CameraSensor  # imports MuJoCo only when asked for
            from vilma.plant3d.laser import LaserSensor
            from vilma.plant3d.plant import MujocoPlant

            self._world_sensors = [CameraSensor(p) for p in c.cameras]
            if c.laser is not None:
                self._world_sensors.append(LaserSensor(c.laser))

            imu = c.sensors.imu.offset if c.sensors.imu is not None else (0.0, 0.0, 0.0)
            self._plant3d = MujocoPlant(c.vehicle, c.world, "".join(s.mjcf() for s in self._world_sensors), imu,
                                        c.road, c.traffic, c.traffic_t0)
            for s in self._world_sensors:
                s.attach(self._plant3d)
        self._capture_periods = np.array(
            [self.clock.period_ticks(s.rate_hz, f"world sensor '{s.name}'") for s in self._world_sensors],
            dtype=np.int64)
        self._captures: list[tuple[str, Message]] = []
        self._model = models.MODELS.index(c.model) if c.model in models.MODELS else -1
        self._integrator = INTEGRATORS.index(c.integrator)
        self.sensors = build_sensors(c.sensors, c.vehicle)
        self._scene = c.scene_sensors()
        self._periods = np.array(  # sample periods [ticks]: the sensors', then the scene sensors'
            [self.clock.period_ticks(s.rate_hz, f"sensor '{s.name}'") for s in [*self.sensors, *self._scene]],
            dtype=np.int64)
        self._bank = SensorBank(self.sensors, self._periods[:len(self.sensors)], self._plant3d is not None)
        self._dead_ticks = self.clock.ticks_for(c.vehicle.actuators.dead_time)
        self._watchdog_ticks = self.clock.ticks_for(c.watchdog_timeout)
        self._kernel_records: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._records, self._records_steps = empty_records(0), 0  # kept: the frames' records, for up to that many steps
        self._records_3d = np.empty((0, N3))  # the 3D plant's beside them
        self._react_ticks = self.clock.ticks_for(c.reactive.period) if c.reactive is not None else 0
        self._frame = None  # run_frame (run_frame_3d) for the types of its arguments, called directly (sim/frame*.py)
        self._plain = not self._world_sensors and not self._react_ticks  # frames need no stop but commands'
        self._run_for = 0.0, 0  # the seconds run_for took last and their ticks
        self.reset(initial)

    # -- state -------------------------------------------------------------------------------------------

    def reset(self, initial: VehicleState | None = None, seed: int | None = None) -> None:
        """Back to time 0 at ``initial`` (default: the configured one), noise reseeded with ``seed``."""
        c = self.config
        if seed is not None:
            self.config = c = dataclasses.replace(c, seed=seed)
        self.clock.tick = 0
        self._z[:] = (initial or c.initial).to_array()
        if self._plant3d is not None:
            self._plant3d.reset(initial or c.initial)
        else:  # lateral states that the model fixes (kinematic: all of them; single track: at low speed)
            constrain_start(self._model, self._z, self._consts)
        for sensor in self.sensors:
            sensor.reset(self._z.copy(), sensor_rng(c.seed, sensor.name))
        self._bank.reset()
        for scene in self._scene:
            scene.reset(sensor_rng(c.seed, scene.name))
        self._mode = MODE_IDS[ActuatorCommand().longitudinal]
        self._cmd[:] = (0.0, 0.0, 0.0, np.inf)
        self._pending: deque[tuple[int, ActuatorCommand]] = deque()
        self._autonomous = False
        self._last_command_tick = 0
        self.watchdog_tripped = False
        self._captures = []
        self._warnings = WarningThrottle(log, clock=lambda: self.clock.time_s)  # a line per sim second at most
        self._args, self._arrays = None, ()  # run_frame's arguments after (n, tick), kept until one of them changes
        self._calm = self._calm_until()
        if c.reactive is not None:
            c.reactive.reset()
            self._react()

    def _react(self) -> None:
        """The reactive traffic's next period, seeing the ego's box centre where it is now."""
        z, offset = self._z.tolist(), self.config.vehicle.body_offset
        self.config.reactive.step(z[X] + offset * math.cos(z[YAW]), z[Y] + offset * math.sin(z[YAW]), z[VX])

    @property
    def state(self) -> VehicleState:
        """The plant now."""
        return VehicleState.from_array(self._z)

    @property
    def plant(self) -> list[float]:
        """The plant vector now, as the fields of :class:`VehicleState` in order (cheaper than :attr:`state`)."""
        return self._z.tolist()

    @property
    def time_ns(self) -> int:
        """Sim time [ns]."""
        return self.clock.time_ns

    @property
    def collisions(self) -> tuple[int, str]:
        """Collisions with the world's obstacles since the last reset, and the last obstacle hit ("" if none)."""
        p = self._plant3d
        return (p.collisions, p.last_collision) if p is not None else (0, "")

    def status(self, real_time_factor: float = float("nan")) -> SimStatus:
        """Status message at the current time (the real-time factor is known only to the pacing layer)."""
        count, last = self.collisions
        return SimStatus(stamp_ns=self.time_ns, real_time_factor=real_time_factor, autonomous=self._autonomous,
                         watchdog_tripped=self.watchdog_tripped, collisions=count, last_collision=last)

    def close(self) -> None:
        """Free the world sensors' renderers (the simulator is not used after; closing again does nothing)."""
        for sensor in self._world_sensors:
            sensor.close()

    def take_captures(self) -> list[tuple[str, Message]]:
        """The world and scene sensors' messages (camera images, laser scans, object lists) made since the last
        call, in time order, with their topic names."""
        out, self._captures = self._captures, []
        return out

    # -- commands ----------------------------------------------------------------------------------------

    def command(self, cmd: ActuatorCommand) -> tuple[str, ...]:
        """Take an actuator command; it acts after the actuators' dead time.

        Returns:
            One note per clamped field (also logged, in one line per sim second at most).

        Raises:
            CommandError: NaN, infinity or an unknown mode; the car keeps its previous command.
        """
        cmd, notes = validate_command(cmd, self.config.vehicle, self._limit_rows)
        if notes:
            self._warnings.warning("clamped", "%s", "; ".join(notes))
        self._last_command_tick = self.clock.tick
        self._autonomous = cmd.autonomous
        if self.watchdog_tripped:
            log.info("watchdog: commands are back at t=%.3f s, resuming", self.clock.time_s)
            self.watchdog_tripped, self._args = False, None
        if self._dead_ticks:
            self._pending.append((self.clock.tick + self._dead_ticks, cmd))
        else:
            self._apply(cmd)
        self._calm = self._calm_until()
        return notes

    def _apply(self, cmd: ActuatorCommand) -> None:
        mode = MODE_IDS[cmd.longitudinal]
        if mode != self._mode:  # the frame's arguments hold the mode (the command is in the plant array they hold)
            self._mode, self._args = mode, None
        c = self._cmd  # item by item: half the time of a slice assigned from a tuple
        c[0], c[1], c[2], c[3] = cmd.steer, cmd.drive, cmd.brake, cmd.velocity_limit

    def _watchdog_deadline(self) -> int | None:
        if self._autonomous and self._watchdog_ticks and not self.watchdog_tripped:
            return self._last_command_tick + self._watchdog_ticks
        return None

    # -- stepping ----------------------------------------------------------------------------------------

    def step(self) -> dict[str, Readings]:
        """Advance one physics step."""
        return self.advance(1)

    def run_for(self, seconds: float) -> dict[str, Readings]:
        """Advance ``seconds`` of sim time (rounded to whole steps)."""
        if seconds != self._run_for[0]:  # a loop of frames asks for the same seconds each time (NaN: never equal)
            self._run_for = seconds, self.clock.ticks_for(seconds)
        return self.advance(self._run_for[1])

    def advance(self, ticks: int) -> dict[str, Readings]:
        """Advance ``ticks`` physics steps; returns the readings made, by sensor name."""
        end = self.clock.tick + ticks
        if ticks > 0 and end < self._calm:  # the common frame: one chunk, no stop to find
            return self._run_chunk(ticks)
        chunks: list[dict[str, Readings]] = []
        while self.clock.tick < end:
            stop = end
            if self._pending:
                stop = min(stop, max(self._pending[0][0], self.clock.tick))
            deadline = self._watchdog_deadline()
            if deadline is not None:
                stop = min(stop, max(deadline, self.clock.tick))
            if self._world_sensors:
                periods = self._capture_periods
                stop = min(stop, int(((self.clock.tick // periods + 1) * periods).min()))
            if self._react_ticks:
                stop = min(stop, (self.clock.tick // self._react_ticks + 1) * self._react_ticks)
            if stop > self.clock.tick:
                chunks.append(self._run_chunk(stop - self.clock.tick))
                if self._world_sensors:
                    self._capture()
                if self._react_ticks and self.clock.tick % self._react_ticks == 0:
                    self._react()
            while self._pending and self._pending[0][0] <= self.clock.tick:
                self._apply(self._pending.popleft()[1])
            if deadline is not None and self.clock.tick >= deadline:
                self.watchdog_tripped, self._args = True, None
                log.warning("watchdog: no command for %.3f s while autonomous at t=%.3f s; stopping the car",
                            self.config.watchdog_timeout, self.clock.time_s)
        self._calm = self._calm_until()
        return chunks[0] if len(chunks) == 1 else self._joined(chunks)

    def _calm_until(self) -> float:
        """The tick at which something stops a chunk (a command takes effect, the watchdog fires; infinity if
        nothing will), kept as ``_calm`` after each change: steps up to a tick before it run in one chunk. Zero
        with world sensors or reactive traffic, whose stops :meth:`advance` finds step by step."""
        if not self._plain:
            return 0
        deadline = self._watchdog_deadline()
        calm = math.inf if deadline is None else deadline
        return min(calm, self._pending[0][0]) if self._pending else calm

    def _joined(self, chunks: list[dict[str, Readings]]) -> dict[str, Readings]:
        """The readings of consecutive chunks, joined by sensor."""
        parts = {s.name: [c[s.name] for c in chunks if s.name in c] for s in self.sensors}
        return {name: Readings.concat(p) for name, p in parts.items() if p}

    def _capture(self) -> None:
        """What the world sensors due at this tick see."""
        tick = self.clock.tick
        for sensor, period in zip(self._world_sensors, self._capture_periods.tolist(), strict=True):
            if tick % period == 0:
                self._captures.extend(sensor.capture(self.clock.time_ns).items())

    def _run_chunk(self, n: int) -> dict[str, Readings]:
        t0 = self.clock.tick
        if n > self._records_steps:  # the records a chunk needs grow with its steps
            periods = self._periods
            self._records = empty_records(min(n, int(np.sum(n // periods + 1))) if len(periods) else 0)
            self._records_steps, self._args = n, None
            if self._plant3d is not None:
                self._records_3d = np.empty((len(self._records[2]), N3))
        args = self._args or self._frame_args()
        m = self._frame(n, t0, *args) if self._plant3d is None else self._frame(n, t0, self._plant3d.data.time, *args)
        if m < 0:  # again after the bank made room
            self._bank.make_room()
            self._rebank()
            return self._run_chunk(n)
        self.clock.tick = t0 + n
        if self._scene:
            self._scan(t0, n, self._records[2][:m], self._records[0], self._records[1])
        return self._bank.readings()

    def _frame_args(self) -> tuple:
        """run_frame's arguments after ``(n, tick)`` (run_frame_3d's after ``(n, tick, t)``), kept for the frames that
        follow until one changes; their table of arrays (:mod:`vilma.core.arrays`) with the arrays it points into,
        which are kept alive as long as it is."""
        bank, (out_z, out_dx, out_tick), mode = self._bank, self._records, STOP if self.watchdog_tripped else self._mode
        sensing = bank.arrays
        if self._plant3d is None:
            arrays = (self._plant, self._periods, out_z, out_dx, out_tick, *sensing)
            args = (self._model, self._integrator, mode, self.clock.step_s, self.clock.step_ns, table(arrays, ARRAYS))
        else:  # the body poses made only for the world sensors
            from vilma.sim.frame3d import ARRAYS_3D, run_frame_3d  # imports MuJoCo

            ptrs, car, traffic, nstep = self._plant3d.kernel_args(self.clock.step_s)
            arrays = (*car, self._plant, self._periods, out_z, out_dx, out_tick, *sensing, self._records_3d)
            args = (ptrs, traffic, mode, self.clock.step_s, nstep, bool(self._world_sensors), self.clock.step_ns,
                    table(arrays, ARRAYS_3D))
        if self._frame is None:  # type the arguments once (ints, floats, C arrays of fixed dtypes), not at each call
            if self._plant3d is None:
                self._frame = direct(run_frame, 0, 0, *args)
            else:
                self._frame = direct(run_frame_3d, 0, 0, 0.0, *args)
        self._args, self._arrays = args, arrays
        return args

    def _rebank(self) -> None:
        """The bank's arrays anew in the frame's table after it made room (new blocks, maybe a larger noise array):
        their rows only (a whole new table cost a 3D frame's sensors a sixth more)."""
        sensing = self._bank.arrays  # (the book stays: where the bank's arrays begin)
        at = next(i for i, a in enumerate(self._arrays) if a is sensing[0])
        self._args[-1][at:at + len(sensing)] = table(sensing, ARRAYS[-len(sensing):])
        self._arrays = (*self._arrays[:at], *sensing, *self._arrays[at + len(sensing):])

    # -- for compiled callers (a closed loop run in compiled code) -----------------------------------------

    @property
    def scene_periods(self) -> np.ndarray:
        """Sample periods [ticks] of the scene sensors (the objects sensor, the planar laser): their scans are made at
        the ticks that are multiples of them."""
        return self._periods[len(self.sensors):]

    @property
    def compiled_ok(self) -> bool:
        """Whether compiled code may advance this simulator: no dead time, no watchdog stop under way."""
        return (self._plant3d is None and not self._dead_ticks and not self._pending
                and not self.watchdog_tripped)

    def advance_compiled(self, ticks: int, kernel: Callable[[PlantKernel], KernelResult]) -> dict[str, Readings]:
        """Let compiled code advance the plant up to ``ticks`` steps; returns the readings, as :meth:`advance`.

        ``kernel`` gets the live plant, a copy of the command in force and the reactive traffic (:class:`PlantKernel`),
        runs :func:`~vilma.vehicle.integrate.advance` on them, steps the traffic at each of its period ends, may
        change the command in place (clamped with ``limits``), and says what it did (:class:`KernelResult`); its
        command stays in force.

        Raises:
            RuntimeError: not :attr:`compiled_ok`.
        """
        k = self.kernel_start(ticks)
        return self.kernel_end(k, kernel(k))

    def kernel_start(self, ticks: int, sensing: bool = True) -> PlantKernel:
        """What compiled code advancing the plant up to ``ticks`` steps works on: :meth:`advance_compiled` in two
        halves, for a caller that advances many simulators in one compiled call (:mod:`vilma.scenario.fleet`);
        :meth:`kernel_end` must follow before anything else is asked of the simulator. Without ``sensing`` the
        sensors skip these steps (no sample recorded, no reading made, no noise drawn): for a caller that would
        throw their readings away.

        Raises:
            RuntimeError: not :attr:`compiled_ok`.
        """
        if not self.compiled_ok:
            raise RuntimeError("this simulator cannot be advanced by compiled code now (see compiled_ok)")
        if self._kernel_records is None or len(self._kernel_records[2]) < ticks:
            self._kernel_records = empty_records(ticks)  # kept: one allocation for the blocks of a run
        return PlantKernel(self._model, self._integrator, self._z, self._consts, self.clock.step_s, self.clock.step_ns,
                           self.clock.tick, self._periods if sensing else NO_PERIODS, self._kernel_records,
                           np.array([self._mode]),
                           self._cmd.copy(), self._limits,
                           None if self.config.reactive is None else self.config.reactive.arrays)

    def kernel_end(self, k: PlantKernel, done: KernelResult) -> dict[str, Readings]:
        """Take what compiled code did to the plant of :meth:`kernel_start`'s ``k``; returns the readings."""
        t0 = k.tick
        self.clock.tick = t0 + done.ticks
        self._mode, self._cmd[:], self._args = int(k.mode[0]), k.cmd, None
        if done.commanded_tick is not None:
            self._autonomous, self._last_command_tick = True, done.commanded_tick
            self._calm = self._calm_until()
        if k.periods is NO_PERIODS:
            return {}
        out_z, out_dx, out_tick = k.records
        ticks = out_tick[:done.records]
        readings = self._bank.measure(t0, done.ticks, ticks, out_z, out_dx, self.clock.step_ns)
        if self._scene:
            self._scan(t0, done.ticks, ticks, out_z, out_dx)
        return readings

    def normals_ahead(self, sensor: Sensor, count: int) -> np.ndarray:
        """The standard normals ``sensor`` (one of :attr:`sensors`) takes for its next ``count`` samples, left for
        it (compiled code measuring as the simulator will: :mod:`vilma.scenario.lockstep_ekf`); planar plant only."""
        return self._bank.normals_ahead(sensor, count)

    def _scan(self, t0: int, n: int, ticks: np.ndarray, out_z: np.ndarray, out_dx: np.ndarray) -> None:
        """The scene sensors' scans of the steps ``t0 + 1 .. t0 + n``, one sensor at a time, from the plant recorded
        at ``ticks``, to the captures."""
        step_ns, scans = self.clock.step_ns, []
        for sensor, period in zip(self._scene, self.scene_periods.tolist(), strict=True):
            first, count = (t0 // period + 1) * period, (t0 + n) // period - t0 // period
            if count:
                s = Samples(rows_of(ticks, period, count), out_z, out_dx)
                stamps = np.arange(first, first + count * period, period, dtype=np.int64) * step_ns
                scans += [(sensor.topic, msg) for msg in sensor.scan(s, stamps)]
        if scans:  # after the 3D plant's captures of the steps before (it stops at theirs)
            self._captures += sorted(scans, key=lambda c: c[1].stamp_ns)
