"""What a world sensor of the 3D plant is: a camera or a laser that looks at the MuJoCo world.

Unlike the vectorised sensors of :mod:`vilma.sensors`, which measure recorded plant states in batches
after the physics ran, a world sensor captures the live MuJoCo scene at its own sample ticks: the
simulator stops the physics there and calls :meth:`WorldSensor.capture`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

from vilma.core.messages import Message

if TYPE_CHECKING:
    from vilma.plant3d.plant import MujocoPlant


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
