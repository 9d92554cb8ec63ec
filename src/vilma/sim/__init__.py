"""The simulator: fixed-step plant, actuators, sensors at their rates, command watchdog; pacing on top."""

from vilma.sim.config import SimConfig
from vilma.sim.pacing import Pacer, PaceStats
from vilma.sim.simulator import Simulator

__all__ = ["PaceStats", "Pacer", "SimConfig", "Simulator"]
