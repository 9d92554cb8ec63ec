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

from vilma.control.path.base import PathOutput
from vilma.core.messages import PoseEstimate
from vilma.trajectory import Trajectory
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


class PurePursuit:
    """Pure pursuit from the rear axle with a speed-scheduled look-ahead."""

    def __init__(self, vehicle: VehicleParams, params: PurePursuitParams | None = None) -> None:
        self.vehicle, self.params = vehicle, params or PurePursuitParams()
        self.period = self.params.period
        self.reset()

    def reset(self) -> None:
        self.hint: int | None = None

    def step(self, pose: PoseEstimate, path: Trajectory) -> PathOutput:
        p, v = self.params, self.vehicle
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        rx, ry = pose.x - v.cg_to_rear * c, pose.y - v.cg_to_rear * s
        proj = path.project(rx, ry, hint=self.hint, window=p.window if self.hint is not None else None)
        self.hint = proj.index
        look = min(max(p.lookahead_min + p.lookahead_gain * abs(pose.speed), p.lookahead_min), p.lookahead_max)
        target_s = proj.s + look
        if target_s <= path.length:
            tx, ty = path.point_at(target_s)
        else:  # past the end: aim along the last heading so the car still reaches the end point
            ex, ey = path.xy[-1]
            h = path.heading[-1]
            tx, ty = ex + (target_s - path.length) * math.cos(h), ey + (target_s - path.length) * math.sin(h)
        dx, dy = tx - rx, ty - ry
        alpha = math.atan2(-s * dx + c * dy, c * dx + s * dy)
        dist = max(math.hypot(dx, dy), 1e-6)
        steer = math.atan(2.0 * v.wheelbase * math.sin(alpha) / dist)
        steer = min(max(steer, -v.max_steer), v.max_steer)
        return PathOutput(steer, proj.index, proj.s)
