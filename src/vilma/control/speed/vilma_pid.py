"""The original VILMA speed controller: a gain-scheduled PID on the engine power.

From ``vilma_self_driver::maintainSpeedWorker`` (vilma-original.md section 2;
paper section 4.3). Every period (250 ms), with ``e = v_d - v`` and ``d`` the
last front-wheel command [rad]:

- ``|e| > 1 m/s``: pure P, ``Kp = 200 + 350|d|``, and the PID is reset;
- otherwise PI: ``Kp = 200 + 350|d|``, ``Ki = 50 + 800|d|``, integral term
  clamped to ``+-(25 v_d + 500|d|)`` (ROS control_toolbox 1.13.1: the integral
  of the error is not clamped, only ``Ki`` times it);
- the power may rise by at most 10 and fall by at most 40 per period;
- it is capped at ``50 v_d + 800|d|``;
- the output is the original's ``powerAmount`` (``power`` mode,
  ``velocityAmount`` 100 as the original transmitter sent).

Quirks of the shipped binary, off by default (the paper's intent), on with
``VilmaPidParams.original()``: ``abs`` is C's integer ``abs`` (so the P-only
regime starts at ``|e| >= 2`` and the |d| terms are truncated), the target is
truncated to an integer, and a negative command is mirrored to positive
instead of clamped at zero. The 250 ms actuation delay and the measured-speed
formula belong to the driver (:class:`~vilma.control.driver.DriverParams`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from numba import njit

from vilma.control.checks import check_params
from vilma.control.registry import SPEED, ControllerType, register
from vilma.vehicle.actuators import POWER
from vilma.vehicle.params import VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class VilmaPidParams:
    """Gains and limits of the original speed controller (original units: power per m/s, per rad)."""

    period: float = 0.25
    """Control period [s]."""
    kp: float = 200.0
    kp_steer: float = 350.0
    """Added to Kp per rad of steering."""
    ki: float = 50.0
    ki_steer: float = 800.0
    i_limit_speed: float = 25.0
    """Integral-term limit per m/s of target."""
    i_limit_steer: float = 500.0
    large_error: float = 1.0
    """Above this |error| [m/s] the controller is pure P and reset."""
    rise_per_period: float = 10.0
    fall_per_period: float = 40.0
    max_power_speed: float = 50.0
    """Power cap per m/s of target."""
    max_power_steer: float = 800.0
    velocity_amount: float = 100.0
    """``velocityAmount`` sent with every power command [m/s]."""
    integer_abs: bool = False
    """Use C ``int abs()`` as the shipped binary: truncate before the absolute value."""
    integer_target: bool = False
    """Truncate the target speed to an integer, as the original ``maintainSpeed(int)``."""
    mirror_negative: bool = False
    """Mirror a negative power to positive (original) instead of clamping it at zero."""

    def __post_init__(self) -> None:
        check_params(self, "vilma_pid")

    @classmethod
    def original(cls) -> VilmaPidParams:
        """The shipped binary's behaviour, quirks included."""
        return cls(integer_abs=True, integer_target=True, mirror_negative=True)


class VilmaPidConsts(NamedTuple):
    """:class:`VilmaPidParams` as compiled code reads them."""

    period: float
    kp: float
    kp_steer: float
    ki: float
    ki_steer: float
    i_limit_speed: float
    i_limit_steer: float
    large_error: float
    rise_per_period: float
    fall_per_period: float
    max_power_speed: float
    max_power_steer: float
    integer_abs: bool
    integer_target: bool
    mirror_negative: bool
    velocity_amount: float


def vilma_pid_consts(p: VilmaPidParams, vehicle: VehicleParams) -> VilmaPidConsts:
    """Flatten the parameters for :func:`vilma_pid_step` (the car plays no part)."""
    return VilmaPidConsts(*(getattr(p, f) for f in VilmaPidConsts._fields))


@njit(cache=True)
def _abs(c, v):
    return float(abs(math.trunc(v))) if c.integer_abs else abs(v)


@njit(cache=True)
def vilma_pid_step(c, st, target, speed, steer):
    """One period: ``power`` mode, the power [original units] for ``target`` and ``speed`` [m/s] and last
    ``steer`` [rad], no brake, ``velocityAmount``.

    ``st`` = ``[integral of the error, last power]``, updated in place.
    """
    v_d = float(math.trunc(target)) if c.integer_target else target
    e = v_d - speed
    kp = c.kp + _abs(c, c.kp_steer * steer)
    if _abs(c, e) > c.large_error:
        st[0] = 0.0  # setGains(Kp, 0, 0, 0, 0) then reset()
        u = kp * e
    else:
        ki = c.ki + _abs(c, c.ki_steer * steer)
        i_max = c.i_limit_speed * v_d + _abs(c, c.i_limit_steer * steer)
        st[0] += c.period * e
        u = kp * e + min(max(ki * st[0], -i_max), i_max)
    u = min(max(u, st[1] - c.fall_per_period), st[1] + c.rise_per_period)
    u = min(u, c.max_power_speed * v_d + _abs(c, c.max_power_steer * steer))
    u = abs(u) if c.mirror_negative else max(u, 0.0)
    st[1] = u
    return POWER, u, 0.0, c.velocity_amount


register(ControllerType("vilma_pid", SPEED, VilmaPidParams, VilmaPidConsts, vilma_pid_consts, (0.0, 0.0),
                        vilma_pid_step))
