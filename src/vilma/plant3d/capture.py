"""What a world sensor of the 3D plant is: a camera or a laser that looks at the MuJoCo world.

Unlike the vectorised sensors of :mod:`vilma.sensors`, which measure recorded plant states in batches
after the physics ran, a world sensor captures the live MuJoCo scene at its own sample ticks: the
simulator stops the physics there and calls :meth:`WorldSensor.capture`.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Protocol

from vilma.core.messages import Message

if TYPE_CHECKING:
    from vilma.plant3d.plant import MujocoPlant

WORD = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
"""A sensor name: it is a topic segment and an MJCF name."""


def all_finite(*values: object) -> bool:
    """Whether every value is a finite real number (not a bool)."""
    return all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in values)


def check_mount(kind: str, name: object, position: object, yaw: object) -> str:
    """Check a world sensor's name and mount (``kind``: ``camera`` or ``laser``); returns how errors name it.

    Raises:
        ValueError: a name that is not a word, a position that is not three finite numbers [m], a yaw that is
            not finite [rad].
    """
    if not (isinstance(name, str) and WORD.fullmatch(name)):
        raise ValueError(f"{kind} name must be a word (letters, digits, _; a letter first), got {name!r}")
    what = f"{kind} {name!r}"
    if not (isinstance(position, tuple) and len(position) == 3 and all_finite(*position)):
        raise ValueError(f"{what} position must be three finite numbers (x, y, z) [m], got {position!r}")
    if not all_finite(yaw):
        raise ValueError(f"{what} yaw must be a finite number [rad], got {yaw!r}")
    return what


class WorldSensor(Protocol):
    """A camera or laser on the car (see the module docstring)."""

    name: str
    """Unique among the car's world sensors; also its frame id."""
    rate_hz: float
    """Sample rate [Hz] (a whole number of physics steps a period)."""

    def mjcf(self) -> str:
        """MJCF elements placed inside the chassis body (cameras, sites), names prefixed by :attr:`name`."""

    def attach(self, plant: MujocoPlant) -> None:
        """Bind to the compiled ``plant`` (look up ids, make renderers); called again after a rebuild."""

    def capture(self, stamp_ns: int) -> dict[str, Message]:
        """Measure the world as it is now: messages stamped ``stamp_ns`` by topic name (``camera/<name>``,
        ``camera/<name>/depth``, ``laser``)."""

    def close(self) -> None:
        """Free renderers and contexts."""
