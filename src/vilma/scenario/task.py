"""What the driver does in a scenario and where the car starts: the ``task`` and ``initial`` sections."""

from __future__ import annotations

from dataclasses import dataclass

from vilma.trajectory.points import MAX_DENSIFY, MAX_POINTS
from vilma.trajectory.smooth import ALPHA, BETA, TOLERANCE, check_iterative


@dataclass(frozen=True, slots=True, kw_only=True)
class SmoothSpec:
    """The paper's Smooth Trajectory (Algorithm 1)."""

    alpha: float = ALPHA
    """weight_data [-]"""
    beta: float = BETA
    """weight_smooth [-]"""
    tolerance: float = TOLERANCE
    """Stop when a sweep changes the points by less than this in total [m]."""
    solver: str = "iterative"
    """``iterative`` (the paper's sweeps) or ``banded`` (the same fixed point solved directly)."""

    def __post_init__(self) -> None:
        if self.solver not in ("iterative", "banded"):
            raise ValueError(f"solver must be 'iterative' or 'banded', got {self.solver!r}")
        if not (self.alpha > 0 and self.beta >= 0 and self.tolerance > 0):
            raise ValueError("alpha must be > 0, beta >= 0 and tolerance > 0")
        if self.solver == "iterative":
            check_iterative(self.alpha, self.beta)


@dataclass(frozen=True, slots=True, kw_only=True)
class PlanSpec:
    """The ``plan`` task: perceive, predict and plan locally along a route (``follow``, ``course``, or a
    CommonRoad world's route) to a goal, stopping there; ``plan: true`` for the defaults."""

    goal: tuple[float, float] | None = None
    """Stop at this point [m] (where it projects on the route); default: the route's end."""


@dataclass(frozen=True, slots=True, kw_only=True)
class TaskSpec:
    """What the driver does. With none of ``go_to``, ``follow``, ``course``, ``route``, ``plan``: hold ``speed``
    straight ahead."""

    speed: float | None = None
    """Target speed [m/s], at most the car's top speed; with ``follow`` it may be left out to use the file's own
    speeds, with ``route`` it caps the lanelets' speed limits."""
    go_to: tuple[float, float] | None = None
    """Drive to this point [m] and stop on it."""
    follow: str | None = None
    """Follow this trajectory file (original ``x y`` format, CSV or GPX), relative to the scenario file."""
    course: tuple[tuple[float, float], ...] | None = None
    """Follow a smooth spline through these points [m]."""
    route: bool = False
    """Drive the CommonRoad planning problem's route (``world.commonroad``; the default task there) to its goal,
    at the lanelets' speed limits."""
    densify: int = 0
    """Apply Increase Point Count this many times (n -> 2n - 1 each), at most
    :data:`~vilma.trajectory.points.MAX_DENSIFY`."""
    smooth: SmoothSpec | None = None
    """Smooth the path as the paper (``true`` for the original's parameters)."""
    resample: float | None = None
    """Resample the path at this spacing [m] (after densify and smooth)."""
    plan: PlanSpec | None = None
    """Drive by the local planner along the route given (``follow``, ``course``, ``route``; a CommonRoad world's
    route without one) at ``speed`` (or the route's speeds), around what perception sees."""

    def __post_init__(self) -> None:
        given = [k for k in ("go_to", "follow", "course", "route") if getattr(self, k) not in (None, False)]
        if len(given) > 1:
            raise ValueError(f"give one of go_to, follow, course, not {' and '.join(given)}")
        if self.plan is not None and self.go_to is not None:
            raise ValueError("a plan drives along a route (follow, course or route), not to a go_to point: give the "
                             "point as plan: {goal: [x, y]}")
        if self.speed is None and not (self.follow or self.route or (self.plan and not self.course)):
            raise ValueError("speed is missing: give the target speed in m/s")
        if self.speed is not None and not self.speed > 0:
            raise ValueError(f"speed must be > 0 m/s, got {self.speed}")
        if self.course is not None and len(self.course) < 2:
            raise ValueError("course needs at least 2 points")
        if not 0 <= self.densify <= MAX_DENSIFY:
            raise ValueError(f"densify must be 0..{MAX_DENSIFY} (each pass doubles the points; a path holds at most "
                             f"{MAX_POINTS}), got {self.densify}")
        if self.resample is not None and not self.resample > 0:
            raise ValueError(f"resample spacing must be > 0 m, got {self.resample}")

    @property
    def kind(self) -> str:
        """``speed``, ``go_to``, ``follow``, ``course``, ``route`` or ``plan``."""
        if self.plan is not None:
            return "plan"
        if self.route:
            return "route"
        return next((k for k in ("go_to", "follow", "course") if getattr(self, k) is not None), "speed")


@dataclass(frozen=True, slots=True, kw_only=True)
class InitialSpec:
    """Where the car starts; unset position and heading: the path's first point, facing along it (else 0)."""

    x: float | None = None
    """[m]"""
    y: float | None = None
    """[m]"""
    yaw: float | None = None
    """[rad], counter-clockwise from east."""
    speed: float = 0.0
    """Forward speed [m/s]."""
