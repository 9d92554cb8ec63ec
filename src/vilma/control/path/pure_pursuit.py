"""Pure pursuit (Coulter, "Implementation of the pure pursuit path tracking algorithm", CMU-RI-TR-92-01, 1992).

From the rear axle centre, aim at the path point a look-ahead distance ``l``
further along (``l = l_min + k v``, clamped), and steer the arc through it:
``delta = atan(2 L sin(alpha) / l)``, with ``alpha`` the bearing of the
target in the car frame. The car is located on the path by projection (a
window around the last segment), not by waypoint index.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from numba import njit

from vilma.control.checks import check_params
from vilma.control.registry import PATH, ControllerType, register
from vilma.trajectory.trajectory import path_point_at, path_project
from vilma.vehicle.params import VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class PurePursuitParams:
    """Look-ahead schedule of pure pursuit."""

    period: float = 0.02
    """Control period [s]."""
    lookahead_min: float = 2.5
    """Look-ahead at standstill [m]."""
    lookahead_gain: float = 0.35
    """Look-ahead added per m/s of speed [s]."""
    lookahead_max: float = 15.0
    """Largest look-ahead [m]."""
    window: int = 40
    """Segments searched on each side of the last projection."""

    def __post_init__(self) -> None:
        check_params(self, "pure_pursuit", positive=("lookahead_min", "lookahead_max"))
        if self.lookahead_max < self.lookahead_min:
            raise ValueError(f"pure_pursuit lookahead_max {self.lookahead_max!r} must be >= lookahead_min "
                             f"{self.lookahead_min!r}")


class PurePursuitConsts(NamedTuple):
    """:class:`PurePursuitParams` and the car's geometry as compiled code reads them."""

    lookahead_min: float
    lookahead_gain: float
    lookahead_max: float
    window: int
    cg_to_rear: float
    wheelbase: float
    max_steer: float


def pure_pursuit_consts(p: PurePursuitParams, vehicle: VehicleParams) -> PurePursuitConsts:
    """The look-ahead schedule and the car's geometry for :func:`pure_pursuit_step`."""
    return PurePursuitConsts(p.lookahead_min, p.lookahead_gain, p.lookahead_max, p.window, vehicle.cg_to_rear,
                             vehicle.wheelbase, vehicle.max_steer)


@njit(cache=True)
def pure_pursuit_step(c, st, pa, x, y, yaw, speed, yaw_rate):
    """One period at pose ``(x, y, yaw)`` and ``speed`` [m/s]: (steer [rad], False: it follows past the end).

    ``st`` = ``[segment of the last projection (-1: none)]``.
    """
    co, si = math.cos(yaw), math.sin(yaw)
    rx, ry = x - c.cg_to_rear * co, y - c.cg_to_rear * si
    i, _, s, _, _, _, _, _ = path_project(pa, rx, ry, int(st[0]), c.window)
    st[0] = i
    look = min(max(c.lookahead_min + c.lookahead_gain * abs(speed), c.lookahead_min), c.lookahead_max)
    target_s = s + look
    length = pa.s[-1]
    if target_s <= length:
        tx, ty = path_point_at(pa, target_s)
    else:  # past the end: aim along the last heading so the car still reaches the end point
        h = pa.heading[-1]
        tx = pa.xy[-1, 0] + (target_s - length) * math.cos(h)
        ty = pa.xy[-1, 1] + (target_s - length) * math.sin(h)
    dx, dy = tx - rx, ty - ry
    alpha = math.atan2(-si * dx + co * dy, co * dx + si * dy)
    dist = max(math.hypot(dx, dy), 1e-6)
    steer = math.atan(2.0 * c.wheelbase * math.sin(alpha) / dist)
    return min(max(steer, -c.max_steer), c.max_steer), False


register(ControllerType("pure_pursuit", PATH, PurePursuitParams, PurePursuitConsts, pure_pursuit_consts, (-1.0,),
                        pure_pursuit_step))
