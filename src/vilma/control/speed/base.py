"""What every speed controller shares."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from vilma.core.messages import Longitudinal


@dataclass(frozen=True, slots=True)
class LongitudinalOutput:
    """The longitudinal half of an actuator command (see :class:`~vilma.core.messages.ActuatorCommand`)."""

    mode: Longitudinal
    drive: float
    brake: float = 0.0
    velocity_limit: float = math.inf


class SpeedController(Protocol):
    """Holds a target speed. ``period`` [s] is how often :meth:`step` must be called."""

    period: float

    def reset(self) -> None:
        """Forget integrators and rate-limiter memory."""

    def step(self, target: float, speed: float, steer: float) -> LongitudinalOutput:
        """One control period: ``target`` and measured ``speed`` [m/s], last steering command ``steer`` [rad]."""
