"""Keyboard driving as the original's PowerTrain keys (vilma-original.md section 7), plus W/A/S/D.

Commands are in the original's ``power`` units (see
:class:`~vilma.core.messages.Longitudinal`): engine force ``powerAmount`` on
each wheel and ``brakeAmount`` per wheel. Held keys combine; releasing
them returns steering and power to zero, as the original.

========== ======== =================================================
key        action   command
========== ======== =================================================
Up, W      gas      power 800 (the original's ``applyEngineForce(-800)``)
R          reverse  power -200 (the original's +200, backwards)
Down, S    brake    brake 40 on each wheel, power 0
H          hand     brake 100 on the two rear wheels = 50 per wheel on four
Left, A    steer    +0.3 rad (left)
Right, D   steer    -0.3 rad (right)
========== ======== =================================================
"""

from __future__ import annotations

import math

from PySide6.QtCore import Qt

from vilma.core.messages import ActuatorCommand, Longitudinal

GAS_POWER = 800.0
"""Original units (engine force per wheel)."""
REVERSE_POWER = -200.0
BRAKE = 40.0
"""Original units (brake per wheel)."""
HAND_BRAKE = 50.0
"""100 on the rear wheels only, spread over four wheels [original units per wheel]."""
STEER = 0.3
"""[rad]"""

K = Qt.Key
ACTIONS: dict[int, str] = {
    K.Key_Up: "gas", K.Key_W: "gas", K.Key_Down: "brake", K.Key_S: "brake", K.Key_R: "reverse",
    K.Key_H: "hand_brake", K.Key_Left: "left", K.Key_A: "left", K.Key_Right: "right", K.Key_D: "right",
}
"""Qt key -> driving action."""


class KeyboardDriver:
    """Turns held keys into actuator commands (``velocity_limit``: the power mode's cut-off speed [m/s])."""

    def __init__(self, velocity_limit: float = 20.0) -> None:
        self.velocity_limit = velocity_limit
        self.held: dict[int, str] = {}

    def handles(self, key: int) -> bool:
        """Whether ``key`` is a driving key."""
        return key in ACTIONS

    def press(self, key: int) -> ActuatorCommand | None:
        """A driving key went down: the command to send (None if nothing changed)."""
        if key not in ACTIONS or key in self.held:
            return None
        self.held[key] = ACTIONS[key]
        return self.command()

    def release(self, key: int) -> ActuatorCommand | None:
        """A driving key went up: the command to send (None if it was not held)."""
        if self.held.pop(key, None) is None:
            return None
        return self.command()

    def release_all(self) -> ActuatorCommand | None:
        """Every key released (the window lost focus): zero command if any key was held."""
        if not self.held:
            return None
        self.held.clear()
        return self.command()

    def command(self) -> ActuatorCommand:
        """The command for the keys held now."""
        acts = set(self.held.values())
        steer = STEER * (("left" in acts) - ("right" in acts))
        brake = max(BRAKE if "brake" in acts else 0.0, HAND_BRAKE if "hand_brake" in acts else 0.0)
        drive = 0.0
        if "brake" not in acts:
            drive = GAS_POWER if "gas" in acts else REVERSE_POWER if "reverse" in acts else 0.0
        limit = self.velocity_limit if math.isfinite(self.velocity_limit) else math.inf
        return ActuatorCommand(steer=steer, longitudinal=Longitudinal.POWER, drive=drive, brake=brake,
                               velocity_limit=limit)
