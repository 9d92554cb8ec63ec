"""Speed controllers: the original's gain-scheduled PID (``vilma_pid``) and a feed-forward PI (``pi_ff``)."""

from vilma.control.speed.base import LongitudinalOutput, SpeedController
from vilma.control.speed.pi_ff import PiFf, PiFfParams
from vilma.control.speed.vilma_pid import VilmaPid, VilmaPidParams

__all__ = ["LongitudinalOutput", "PiFf", "PiFfParams", "SpeedController", "VilmaPid", "VilmaPidParams"]
