"""What every pose estimator offers."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from vilma.core.messages import PoseEstimate
from vilma.sensors import Readings


@runtime_checkable
class PoseEstimator(Protocol):
    """Turns sensor readings into a pose estimate of the centre of mass."""

    @property
    def estimate(self) -> PoseEstimate | None:
        """The latest estimate, None before the first."""

    def reset(self) -> None:
        """Forget everything."""

    def update(self, readings: dict[str, Readings]) -> PoseEstimate | None:
        """Take the readings of one simulator call (by sensor name, each in time order), merged by stamp.

        Returns the latest estimate, or None while the estimator has not started.
        """
