"""What the actuators apply now: front-wheel angle, drive and brake force (the ``actuators`` topic)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vilma.core.checks import check_numbers
from vilma.core.messages import ActuatorState
from vilma.sensors.base import Samples
from vilma.vehicle.state import BRAKE, STEER


@dataclass(frozen=True, slots=True, kw_only=True)
class ActuatorStateParams:
    """Actuator state report."""

    rate_hz: float = 50.0
    """Report rate [Hz]."""

    def __post_init__(self) -> None:
        check_numbers(self, "sensor actuator_state", positive=("rate_hz",))


class ActuatorStateSensor:
    """Applied steer [rad], drive force [N], brake force [N], exact."""

    name = "actuators"
    message = ActuatorState

    def __init__(self, params: ActuatorStateParams) -> None:
        self.params, self.rate_hz = params, params.rate_hz

    def reset(self, z0: np.ndarray, rng: np.random.Generator) -> None:
        """Nothing to reset: the report is exact."""

    def measure(self, s: Samples) -> np.ndarray:
        return s.z[s.rows, STEER:BRAKE + 1]
