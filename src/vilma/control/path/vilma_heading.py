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

from vilma.control.path.base import PathOutput
from vilma.core.geometry import heading_from_north_ccw, wrap_angle
from vilma.core.messages import PoseEstimate
from vilma.trajectory import Trajectory


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
    return ang - float(heading_from_north_ccw(yaw))


class VilmaHeading:
    """Turn-Wheels: steer at the active waypoint, advance when it falls behind."""

    def __init__(self, params: VilmaHeadingParams | None = None) -> None:
        self.params = params or VilmaHeadingParams()
        self.period = self.params.period
        self.reset()

    def reset(self) -> None:
        self.active = 0
        self.steer = 0.0

    def step(self, pose: PoseEstimate, path: Trajectory) -> PathOutput:
        p = self.params
        if self.active >= len(path):
            return PathOutput(0.0, len(path) - 1, path.length, done=True)
        tx, ty = path.xy[self.active]
        dx, dy = float(tx) - pose.x, float(ty) - pose.y
        if p.original_quirks:
            err = original_heading_error(dx, dy, pose.yaw)
            behind = abs(math.trunc(err)) > p.behind
        else:
            err = float(wrap_angle(math.atan2(dy, dx) - pose.yaw))
            behind = abs(err) > p.behind
        if behind:
            self.active += 1
        else:
            self.steer = min(max(p.gain * err, -p.max_steer), p.max_steer)
        index = min(self.active, len(path) - 1)
        return PathOutput(self.steer, index, float(path.s[index]), done=self.active >= len(path))
