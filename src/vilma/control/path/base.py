"""What every path controller shares."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

from vilma.core.messages import PoseEstimate
from vilma.trajectory import Trajectory


@dataclass(frozen=True, slots=True)
class PathOutput:
    """A path controller's decision: front-wheel angle [rad] and where on the path it is."""

    steer: float
    index: int
    """Active waypoint (``vilma_heading``) or the segment the car projects onto."""
    progress: float
    """Arc length along the path [m] (of the active waypoint for ``vilma_heading``)."""
    done: bool = False
    """The controller has no more path to follow."""


class PathController(Protocol):
    """Steers along a trajectory. ``period`` [s] is how often :meth:`step` must be called."""

    period: float

    def reset(self) -> None:
        """Start again from the beginning of the path."""

    def step(self, pose: PoseEstimate, path: Trajectory) -> PathOutput:
        """One control period from the estimated pose of the centre of mass."""
