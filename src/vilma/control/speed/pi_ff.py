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

from vilma.control.speed.base import LongitudinalOutput
from vilma.core.messages import Longitudinal
from vilma.vehicle.params import GRAVITY, VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class PiFfParams:
    """Gains and limits of :class:`PiFf`."""

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


class PiFf:
    """Feed-forward PI on a jerk-limited reference; composed with the car's parameters for the feed-forward."""

    def __init__(self, vehicle: VehicleParams, params: PiFfParams | None = None) -> None:
        self.vehicle, self.params = vehicle, params or PiFfParams()
        self.period = self.params.period
        self.reset()

    def reset(self) -> None:
        self.v_ref: float | None = None
        self.a_ref = self.j_ref = 0.0
        self.integral = 0.0

    def _shape(self, target: float) -> None:
        """Move the reference toward ``target`` with acceleration and jerk limits, stopping exactly on it."""
        p, dt = self.params, self.period
        gap = target - self.v_ref
        # the acceleration that still lets a jerk-limited ramp-down land on the target
        a_land = math.copysign(math.sqrt(2.0 * p.max_jerk * abs(gap)), gap)
        a_want = min(max(a_land, -p.max_decel), p.max_accel)
        da = min(max(a_want - self.a_ref, -p.max_jerk * dt), p.max_jerk * dt)
        self.a_ref += da
        self.j_ref = da / dt
        step = self.a_ref * dt
        if (gap > 0 and step >= gap) or (gap < 0 and step <= gap) or gap == 0:
            self.v_ref, self.a_ref, self.j_ref = target, 0.0, 0.0
        else:
            self.v_ref += step

    def step(self, target: float, speed: float, steer: float) -> LongitudinalOutput:
        p, v = self.params, self.vehicle
        if self.v_ref is None:
            self.v_ref = speed
        self._shape(target)
        e = self.v_ref - speed
        lead = self.vehicle.actuators.drive_time_constant + 0.5 * self.period
        a = self.a_ref + lead * self.j_ref + p.kp * e + p.ki * self.integral
        saturated = (a > p.max_accel and e > 0) or (a < -p.max_decel and e < 0)
        if not saturated:
            self.integral += e * self.period
        a = min(max(a, -p.max_decel), p.max_accel)
        resist = 0.5 * v.air_density * v.drag_area * speed * abs(speed) + math.copysign(
            v.rolling_resistance * v.mass * GRAVITY, speed) * (abs(speed) > 0.05)
        force = v.mass * a + resist
        if force >= 0.0:
            return LongitudinalOutput(Longitudinal.FORCE, force)
        return LongitudinalOutput(Longitudinal.FORCE, 0.0, brake=-force)
