"""Stanley steering (Hoffmann, Tomlin, Montemerlo, Thrun, ACC 2007), with feed-forward.

Classic law at the front axle: ``delta = psi_e + atan(-k e / (k_s + v))``
with ``psi_e`` the path heading minus the car's, ``e`` the signed
cross-track error (positive left) and ``k_s`` the softening speed. vilma
adds what the paper's authors list as refinements: the front tyre slip at
steady cornering, ``m lr v^2 kappa / (L C_f)`` from the car's parameters,
and yaw-rate damping. With ``point = "cg"`` the law acts at the centre of
mass instead, with the kinematic feed-forward ``atan(L kappa)`` and the
steady-state sideslip ``atan(lr kappa)`` subtracted from the heading error,
so the centre of mass (the pose the scorecard measures) rides the path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from numba import njit

from vilma.control.checks import check_params
from vilma.control.registry import PATH, ControllerType, register
from vilma.core.geometry import wrap
from vilma.trajectory.trajectory import CURVATURE_SPAN, path_curvature_at, path_heading_at, path_project
from vilma.vehicle.params import VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class StanleyParams:
    """Gains of the Stanley controller."""

    period: float = 0.02
    """Control period [s]."""
    gain: float = 5.0
    """Cross-track gain k [1/s]."""
    softening: float = 1.0
    """Softening speed k_s [m/s]."""
    heading_gain: float = 1.0
    """Heading-error gain [-]."""
    yaw_rate_damping: float = 0.05
    """Damping on the yaw rate minus the path's, [rad per rad/s]."""
    point: str = "cg"
    """Where the law acts: ``cg`` (centre of mass) or ``front_axle`` (the original Stanley)."""
    window: int = 40
    """Segments searched on each side of the last projection."""

    def __post_init__(self) -> None:
        check_params(self, "stanley", positive=("softening",))
        if self.point not in ("cg", "front_axle"):
            raise ValueError(f"stanley point must be 'cg' or 'front_axle', got {self.point!r}")


class StanleyConsts(NamedTuple):
    """:class:`StanleyParams` and the car's parameters as compiled code reads them."""

    gain: float
    softening: float
    heading_gain: float
    yaw_rate_damping: float
    front_axle: bool
    window: int
    cg_to_front: float
    cg_to_rear: float
    wheelbase: float
    max_steer: float
    slip: float
    """Understeer feed-forward per (m/s)^2 of speed and 1/m of curvature: m lr / (L C_f) [rad s^2/m]."""


def stanley_consts(p: StanleyParams, v: VehicleParams) -> StanleyConsts:
    """The gains and the car's geometry and tyres for :func:`stanley_step`."""
    return StanleyConsts(p.gain, p.softening, p.heading_gain, p.yaw_rate_damping, p.point == "front_axle", p.window,
                         v.cg_to_front, v.cg_to_rear, v.wheelbase, v.max_steer,
                         v.mass * v.cg_to_rear / (v.wheelbase * v.cornering_stiffness_front))


@njit(cache=True)
def stanley_step(c, st, pa, x, y, yaw, speed, yaw_rate):
    """One period at pose ``(x, y, yaw)``, ``speed`` [m/s], ``yaw_rate`` [rad/s]: (steer [rad], False: it
    follows past the end).

    ``st`` = ``[segment of the last projection (-1: none)]``.
    """
    ahead = c.cg_to_front if c.front_axle else 0.0
    px, py = x + ahead * math.cos(yaw), y + ahead * math.sin(yaw)
    i, _, s, cross, _, _, _, _ = path_project(pa, px, py, int(st[0]), c.window)
    st[0] = i
    kappa = path_curvature_at(pa, s, CURVATURE_SPAN)
    path_heading = path_heading_at(pa, s, 1.0)
    speed = abs(speed)
    slip = c.slip * speed * speed * kappa
    if c.front_axle:
        feed = slip
        heading_err = wrap(path_heading - yaw)
    else:
        feed = math.atan(c.wheelbase * kappa) + slip
        heading_err = wrap(path_heading - math.atan(c.cg_to_rear * kappa) - yaw)
    damping = c.yaw_rate_damping * (speed * kappa - yaw_rate)
    steer = feed + c.heading_gain * heading_err + math.atan2(-c.gain * cross, c.softening + speed) + damping
    return min(max(steer, -c.max_steer), c.max_steer), False


register(ControllerType("stanley", PATH, StanleyParams, StanleyConsts, stanley_consts, (-1.0,), stanley_step))
