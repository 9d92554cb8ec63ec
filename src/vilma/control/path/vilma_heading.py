"""The paper's Turn-Wheels path controller (section 4.2, Figure 9; vilma-original.md section 3).

Each period it steers the front wheels by the heading error toward the active
waypoint (gain 1, clamped to +-0.6 rad). When that error exceeds 0.6 rad the
waypoint is taken to be behind the car and the next one becomes active (one
per period, the steering kept meanwhile, as the original). There is no
distance-based switching.

Default: the paper's intent, heading error wrapped to (-pi, pi]. With
``original_quirks`` it computes as the shipped binary: heading measured from
+y with the quadrant logic and 3.14 instead of pi, no wrapping, and C's
integer ``abs`` in the behind test (so it fires only at |error| >= 1 rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from numba import njit

from vilma.control.checks import check_params
from vilma.control.registry import PATH, ControllerType, register
from vilma.core.geometry import wrap
from vilma.vehicle.params import VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class VilmaHeadingParams:
    """Parameters of the Turn-Wheels controller."""

    period: float = 0.02
    """Control period [s] (the original ran every 17 ms; the period must be a whole number of physics steps)."""
    gain: float = 1.0
    """Front-wheel angle per rad of heading error."""
    max_steer: float = 0.6
    """Steering clamp [rad]."""
    behind: float = 0.6
    """Heading error [rad] above which the waypoint is behind: go to the next."""
    original_quirks: bool = False
    """Compute as the shipped binary (see module docstring)."""

    def __post_init__(self) -> None:
        check_params(self, "vilma_heading", positive=("max_steer", "behind"))


@njit(cache=True)
def original_heading_error(dx: float, dy: float, yaw: float) -> float:
    """The original's ``value_to_turn`` toward a point ``(dx, dy)`` away [m]: from +y, 3.14, no wrapping.

    ``yaw`` is the ENU yaw [rad], converted here to the original's (from +y).
    The cases the original's branches miss (``dy == 0`` with ``dx < 0``,
    ``dx == 0`` with ``dy < 0``) keep the bare ``atan(dx / dy)`` as in C;
    the car standing exactly on the point (C's 0/0) gives 0.
    """
    if dy != 0.0:
        ang = math.atan(dx / dy)
    elif dx != 0.0:
        ang = math.copysign(math.pi / 2, dx) * math.copysign(1.0, dy)
    else:
        return 0.0
    if (dx >= 0 and dy >= 0) or (dx < 0 < dy):
        ang = -ang
    elif dx < 0 and dy < 0:
        ang = 3.14 - ang
    elif dx > 0 > dy:
        ang = -3.14 - ang
    return ang - wrap(yaw - math.pi / 2.0)  # the original's heading, from +y


class VilmaHeadingConsts(NamedTuple):
    """:class:`VilmaHeadingParams` as compiled code reads them."""

    gain: float
    max_steer: float
    behind: float
    original_quirks: bool


def vilma_heading_consts(p: VilmaHeadingParams, vehicle: VehicleParams) -> VilmaHeadingConsts:
    """Flatten the parameters for :func:`vilma_heading_step` (the car plays no part)."""
    return VilmaHeadingConsts(p.gain, p.max_steer, p.behind, p.original_quirks)


@njit(cache=True)
def vilma_heading_step(c, st, pa, x, y, yaw, speed, yaw_rate):
    """One period at pose ``(x, y, yaw)``: (steer [rad], passed the last waypoint).

    ``st`` = ``[active waypoint, last steer]``; ``pa`` the path's :class:`~vilma.trajectory.PathArrays`.
    """
    n = pa.xy.shape[0]
    active = int(st[0])
    if active >= n:
        return 0.0, True
    dx, dy = pa.xy[active, 0] - x, pa.xy[active, 1] - y
    if c.original_quirks:
        err = original_heading_error(dx, dy, yaw)
        behind = abs(math.trunc(err)) > c.behind
    else:
        err = wrap(math.atan2(dy, dx) - yaw)
        behind = abs(err) > c.behind
    if behind:
        st[0] = active + 1
    else:
        st[1] = min(max(c.gain * err, -c.max_steer), c.max_steer)
    return st[1], int(st[0]) >= n


register(ControllerType("vilma_heading", PATH, VilmaHeadingParams, VilmaHeadingConsts, vilma_heading_consts,
                        (0.0, 0.0), vilma_heading_step))
