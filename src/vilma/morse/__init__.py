"""MORSE-compatible socket interface: MORSE clients (pymorse 1.4, raw sockets, the original VILMA program)
drive and read vilma's simulator unchanged.

:class:`MorseServer` serves MORSE's service port (``simulation``, ``time``, the robot's services) and one
datastream per component; :mod:`vilma.morse.components` lists the components and their units.
"""

from vilma.morse.components import COMPONENTS, STEER_BRAKE_UNIT, STEER_FORCE_UNIT, OriginalCar
from vilma.morse.server import MorseServer

__all__ = ["COMPONENTS", "STEER_BRAKE_UNIT", "STEER_FORCE_UNIT", "MorseServer", "OriginalCar"]
