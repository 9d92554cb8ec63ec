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

from vilma.control.path.base import PathOutput
from vilma.core.geometry import wrap_angle
from vilma.core.messages import PoseEstimate
from vilma.trajectory import Trajectory
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
        if self.point not in ("cg", "front_axle"):
            raise ValueError(f"stanley point must be 'cg' or 'front_axle', got {self.point!r}")


class Stanley:
    """Stanley lateral control with curvature and tyre-slip feed-forward."""

    def __init__(self, vehicle: VehicleParams, params: StanleyParams | None = None) -> None:
        self.vehicle, self.params = vehicle, params or StanleyParams()
        self.period = self.params.period
        self.reset()

    def reset(self) -> None:
        self.hint: int | None = None

    def step(self, pose: PoseEstimate, path: Trajectory) -> PathOutput:
        p, v = self.params, self.vehicle
        c, s = math.cos(pose.yaw), math.sin(pose.yaw)
        ahead = v.cg_to_front if p.point == "front_axle" else 0.0
        px, py = pose.x + ahead * c, pose.y + ahead * s
        proj = path.project(px, py, hint=self.hint, window=p.window if self.hint is not None else None)
        self.hint = proj.index
        kappa = path.curvature_at(proj.s)
        path_heading = path.heading_at(proj.s)
        speed = abs(pose.speed)
        slip = v.mass * v.cg_to_rear * speed * speed * kappa / (v.wheelbase * v.cornering_stiffness_front)
        if p.point == "cg":
            feed = math.atan(v.wheelbase * kappa) + slip
            heading_err = float(wrap_angle(path_heading - math.atan(v.cg_to_rear * kappa) - pose.yaw))
        else:
            feed = slip
            heading_err = float(wrap_angle(path_heading - pose.yaw))
        damping = p.yaw_rate_damping * (speed * kappa - pose.yaw_rate)
        steer = feed + p.heading_gain * heading_err + math.atan2(-p.gain * proj.cross_track,
                                                                 p.softening + speed) + damping
        steer = min(max(steer, -v.max_steer), v.max_steer)
        return PathOutput(steer, proj.index, proj.s)
