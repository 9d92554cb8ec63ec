"""Actuators: command validation, command -> force targets, and the actuators' own dynamics.

A command (:class:`~vilma.core.messages.ActuatorCommand`) is validated in
Python (NaN or infinity rejected naming the field, out-of-range values
clamped and reported), then turned into targets for the front-wheel angle,
drive force and brake force each physics step (:func:`targets`), which the
actuators follow with a first-order lag, and the steering also with a rate
limit (:func:`actuator_step`, exact for a target held over the step).
"""

from __future__ import annotations

import math
import operator

import msgspec
import numpy as np
from numba import njit

from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.vehicle.models.common import V_SIGN
from vilma.vehicle.params import PlantConsts, VehicleParams
from vilma.vehicle.state import VX, VY

FORCE, ACCEL, POWER, STOP = 0, 1, 2, 3
"""Longitudinal modes as compiled ids; STOP is the watchdog's controlled stop."""
MODE_IDS = {Longitudinal.FORCE: FORCE, Longitudinal.ACCEL: ACCEL, Longitudinal.POWER: POWER}

ORIGINAL_OVERSPEED_BRAKE = 30.0
"""Brake the original applies on each wheel above ``velocityAmount`` (``applyBraking(30)``), original units."""


class CommandError(ValueError):
    """A command that cannot be applied (NaN, infinity, unknown mode)."""


COMMAND_FIELDS = ("steer", "drive", "brake", "velocity_limit")
"""The numeric fields of a command, in the order of :func:`command_limits`' columns."""
_numbers = operator.attrgetter(*COMMAND_FIELDS)


def command_limits(p: VehicleParams) -> np.ndarray:
    """Ranges of the command fields by longitudinal mode: ``[mode id, field, (low, high)]``, shape (3, 4, 2)."""
    a = p.actuators
    top = p.max_drive_force / p.power_unit_force
    out = np.empty((3, 4, 2))
    out[:, 0] = (-p.max_steer, p.max_steer)
    out[:, 3] = (0.0, math.inf)
    out[FORCE, 1:3] = ((-p.max_drive_force, p.max_drive_force), (0.0, p.max_brake_force))
    out[ACCEL, 1:3] = ((-a.max_decel, a.max_accel), (0.0, p.max_brake_force))
    out[POWER, 1:3] = ((-top, top), (0.0, p.max_brake_force / (4.0 * p.brake_unit_force)))
    return out


@njit(cache=True)
def clamp_command(limits, mode, cmd):
    """Clamp ``cmd`` (steer, drive, brake, velocity limit) in place to the ranges of ``mode`` (a validated command)."""
    for k in range(4):
        cmd[k] = min(max(cmd[k], limits[mode, k, 0]), limits[mode, k, 1])


def validate_command(cmd: ActuatorCommand, p: VehicleParams,
                     limits: list | None = None) -> tuple[ActuatorCommand, tuple[str, ...]]:
    """Check a command against the car (``limits``: its :func:`command_limits` as nested lists, ``.tolist()``, if the
    caller keeps them: a row of the array made a list at each command cost a quarter of its check).

    Returns:
        The command with out-of-range values clamped, and one note per clamped field.

    Raises:
        CommandError: a field is NaN or infinite (``velocity_limit`` may be
            +inf, meaning no limit), or the longitudinal mode is unknown.
    """
    mode = cmd.longitudinal
    if type(mode) is not Longitudinal:  # a plain string, from Python code: made the enum (or refused)
        try:
            mode = Longitudinal(mode)
        except ValueError:
            raise CommandError(
                f"command field 'longitudinal' is {cmd.longitudinal!r}: use one of "
                f"{', '.join(m.value for m in Longitudinal)}"
            ) from None
        cmd = msgspec.structs.replace(cmd, longitudinal=mode)
    lo_hi = (command_limits(p).tolist() if limits is None else limits)[MODE_IDS[mode]]
    values = _numbers(cmd)
    (s0, s1), (d0, d1), (b0, b1), (v0, v1) = lo_hi
    steer, drive, brake, velocity_limit = values
    if (type(steer) is type(drive) is type(brake) is type(velocity_limit) is float and s0 <= steer <= s1
            and d0 <= drive <= d1 and b0 <= brake <= b1 and v0 <= velocity_limit <= v1):
        return cmd, ()  # the usual command, checked at once: floats within range (NaN fails, infinity too but +inf)
    notes: list[str] = []
    changes: dict[str, float] = {}
    for name, v, (lo, hi) in zip(COMMAND_FIELDS, values, lo_hi, strict=True):
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise CommandError(f"command field '{name}' is {v!r}: must be a number")
        if math.isnan(v) or (math.isinf(v) and not (name == "velocity_limit" and v > 0)):
            raise CommandError(f"command field '{name}' is {v}: must be a finite number")
        if v < lo or v > hi:
            changes[name] = min(max(v, lo), hi)
            notes.append(f"command field '{name}' = {v:g} out of [{lo:g}, {hi:g}] ({mode.value} mode), "
                         f"clamped to {changes[name]:g}")
    if changes:
        cmd = msgspec.structs.replace(cmd, **changes)
    return cmd, tuple(notes)


@njit(cache=True, inline="always")  # a call would copy the 30 plant constants
def targets(mode, cmd, x, u, p):
    """Actuator targets ``(steer [rad], drive [N], brake [N])`` for a command.

    ``cmd`` is ``(steer, drive, brake, velocity_limit)`` as in
    :class:`~vilma.core.messages.ActuatorCommand`, already validated; ``x``
    the vehicle state and ``u`` the actuators' present outputs.
    ``accel`` mode adds the car's own resistance (feed-forward) to
    ``m a``; it drives forward and brakes to a stop, never backwards.
    """
    if mode == STOP:
        return u[0], 0.0, p.m * p.stop_decel
    if mode == FORCE:
        return cmd[0], cmd[1], cmd[2]
    vx = x[VX]
    if mode == ACCEL:
        need = p.m * cmd[1] + p.k_drag * vx * abs(vx) + p.f_roll * math.tanh(vx / V_SIGN)
        if need >= 0.0:
            return cmd[0], need, cmd[2]
        return cmd[0], 0.0, cmd[2] - need
    if math.hypot(vx, x[VY]) < cmd[3]:
        return cmd[0], p.power_unit * cmd[1], 4.0 * p.brake_unit * cmd[2]
    return cmd[0], 0.0, 4.0 * p.brake_unit * ORIGINAL_OVERSPEED_BRAKE


@njit(cache=True)
def lag_gain(tau, dt):
    """Share of the gap a first-order lag of time constant ``tau`` [s] closes in ``dt`` [s] (1 if tau <= 0)."""
    return 1.0 if tau <= 0.0 else 1.0 - math.exp(-dt / tau)


@njit(cache=True)
def actuator_step(u, steer, drive, brake, p, dt):
    """Advance the actuators ``u = (steer, drive, brake)`` one step toward the targets, in place."""
    steer = min(max(steer, -p.max_steer), p.max_steer)
    d = lag_gain(p.tau_steer, dt) * (steer - u[0])
    limit = p.rate_steer * dt
    u[0] += min(max(d, -limit), limit)
    u[1] += lag_gain(p.tau_drive, dt) * (drive - u[1])
    u[2] += lag_gain(p.tau_brake, dt) * (max(brake, 0.0) - u[2])


@njit(cache=True)
def consts_of(a):
    """The :class:`~vilma.vehicle.params.PlantConsts` whose fields are the array ``a``, in order."""
    return PlantConsts(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14],
                       a[15], a[16], a[17], a[18], a[19], a[20], a[21], a[22], a[23], a[24], a[25], a[26], a[27],
                       a[28], a[29])


@njit(cache=True)
def actuate(mode, cmd, x, u, consts, dt):
    """:func:`targets` then :func:`actuator_step` (``u`` in place), the constants as an array (:func:`consts_of`):
    one call from Python for the two, and their arguments cross cheaply (:mod:`vilma.sim.frame`)."""
    p = consts_of(consts)
    steer, drive, brake = targets(mode, cmd, x, u, p)
    actuator_step(u, steer, drive, brake, p, dt)
