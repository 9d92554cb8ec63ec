"""A feed-forward PI speed controller with a shaped reference (vilma's improvement on the original).

The target is approached along a reference speed ``v_r`` limited in
acceleration and jerk; the force request is::

    F = m (a_r + T j_r + Kp (v_r - v) + Ki int(v_r - v)) + drag(v) + rolling(v)

where ``j_r`` is the reference jerk and ``T`` the drive lag plus half a
period (the request leads the reference by what the actuator loses), with
the plant's drag ``1/2 rho CdA v|v|`` and rolling resistance as
feed-forward, the integrator frozen while the output saturates
(conditional-integration anti-windup), and negative forces sent to the
brakes. Output: ``force`` commands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from numba import njit

from vilma.control.checks import check_params
from vilma.control.registry import SPEED, ControllerType, register
from vilma.vehicle.actuators import FORCE
from vilma.vehicle.params import GRAVITY, VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class PiFfParams:
    """Gains and limits of the feed-forward PI."""

    period: float = 0.04
    """Control period [s]."""
    kp: float = 1.2
    """Proportional gain [1/s] (acceleration per m/s of error)."""
    ki: float = 0.3
    """Integral gain [1/s^2]."""
    max_accel: float = 2.0
    """Largest acceleration of the reference and of the request [m/s^2]."""
    max_decel: float = 3.0
    """Largest deceleration [m/s^2]."""
    max_jerk: float = 2.0
    """Largest rate of change of the reference acceleration [m/s^3]."""

    def __post_init__(self) -> None:
        check_params(self, "pi_ff", positive=("max_accel", "max_decel", "max_jerk"))


class PiFfConsts(NamedTuple):
    """:class:`PiFfParams` and the car's resistances as compiled code reads them."""

    period: float
    kp: float
    ki: float
    max_accel: float
    max_decel: float
    max_jerk: float
    lead: float
    """Drive lag plus half a period [s]."""
    mass: float
    drag: float
    """1/2 rho CdA [kg/m]."""
    rolling: float
    """Rolling resistance force [N]."""


def pi_ff_consts(p: PiFfParams, vehicle: VehicleParams) -> PiFfConsts:
    """Flatten the parameters for :func:`pi_ff_step`."""
    return PiFfConsts(p.period, p.kp, p.ki, p.max_accel, p.max_decel, p.max_jerk,
                      vehicle.actuators.drive_time_constant + 0.5 * p.period, vehicle.mass,
                      0.5 * vehicle.air_density * vehicle.drag_area,
                      vehicle.rolling_resistance * vehicle.mass * GRAVITY)


@njit(cache=True)
def _shape(c, st, target):
    """Move the reference toward ``target`` with acceleration and jerk limits, stopping exactly on it."""
    dt = c.period
    gap = target - st[0]
    # the acceleration that still lets a jerk-limited ramp-down land on the target
    a_land = math.copysign(math.sqrt(2.0 * c.max_jerk * abs(gap)), gap)
    a_want = min(max(a_land, -c.max_decel), c.max_accel)
    da = min(max(a_want - st[1], -c.max_jerk * dt), c.max_jerk * dt)
    st[1] += da
    st[2] = da / dt
    step = st[1] * dt
    if (gap > 0 and step >= gap) or (gap < 0 and step <= gap) or gap == 0:
        st[0], st[1], st[2] = target, 0.0, 0.0
    else:
        st[0] += step


@njit(cache=True)
def pi_ff_step(c, st, target, speed, steer):
    """One period: ``force`` mode, drive and brake forces [N] for ``target`` and ``speed`` [m/s], no speed limit.

    ``st`` = ``[reference speed (NaN before the first step), its acceleration, its jerk, integral]``.
    """
    if math.isnan(st[0]):
        st[0] = speed
    _shape(c, st, target)
    e = st[0] - speed
    a = st[1] + c.lead * st[2] + c.kp * e + c.ki * st[3]
    saturated = (a > c.max_accel and e > 0) or (a < -c.max_decel and e < 0)
    if not saturated:
        st[3] += e * c.period
    a = min(max(a, -c.max_decel), c.max_accel)
    resist = c.drag * speed * abs(speed) + (math.copysign(c.rolling, speed) if abs(speed) > 0.05 else 0.0)
    force = c.mass * a + resist
    return (FORCE, force, 0.0, math.inf) if force >= 0.0 else (FORCE, 0.0, -force, math.inf)


register(ControllerType("pi_ff", SPEED, PiFfParams, PiFfConsts, pi_ff_consts, (math.nan, 0.0, 0.0, 0.0),
                        pi_ff_step))
