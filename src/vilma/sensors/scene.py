"""What the sensors of the world around the car share: the traffic they see and the messages they make.

A scene sensor samples the plant at its rate as the other sensors do (:class:`~vilma.sensors.base.Samples`,
measured after each block, also in the compiled closed loop), but makes messages of varying size (a laser
scan, a list of objects), which the simulator hands on with the 3D plant's captures.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from vilma.core.messages import Message
from vilma.sensors.base import Samples

if TYPE_CHECKING:  # the roads extra
    from vilma.world.traffic import Traffic


@dataclass(frozen=True, slots=True)
class Scene:
    """The obstacles a scene sensor sees (the arrays of :class:`~vilma.world.traffic.Traffic`, ``m`` of them, and
    its ``ring``), and ``t0``: their time [s] from their time step 0 at sim time 0 (the planning problem's initial
    step)."""

    ids: np.ndarray
    static: np.ndarray
    outline: np.ndarray
    states: np.ndarray
    present: np.ndarray
    dt: float
    t0: float = 0.0
    ring: bool = False

    @classmethod
    def of(cls, traffic: Traffic | None, t0: float = 0.0) -> Scene:
        """The scene of ``traffic`` (None: an empty world)."""
        if traffic is None:
            return cls(np.zeros(0, np.int64), np.zeros(0, bool), np.zeros((0, 1, 2)), np.zeros((0, 1, 4)),
                       np.zeros((0, 1), bool), 1.0)
        return cls(traffic.ids, traffic.static, traffic.outline, traffic.states, traffic.present, traffic.dt, t0,
                   traffic.ring)

    @property
    def radius(self) -> np.ndarray:
        """Each obstacle's farthest outline vertex from its reference point, (m,) [m]."""
        return np.hypot(self.outline[..., 0], self.outline[..., 1]).max(axis=1, initial=0.0)

    @property
    def size(self) -> np.ndarray:
        """Each obstacle's outline's extent along its x (length) and y (width), (m, 2) [m]."""
        return self.outline.max(axis=1, initial=-np.inf) - self.outline.min(axis=1, initial=np.inf)

    def times(self, stamp_ns: np.ndarray) -> np.ndarray:
        """The obstacles' times [s] at sim times ``stamp_ns`` [ns]."""
        return self.t0 + stamp_ns * 1e-9


class SceneSensor(Protocol):
    """A sensor of the world around the car, publishing on ``topic`` at ``rate_hz``."""

    name: str
    topic: str
    rate_hz: float

    def reset(self, rng: np.random.Generator) -> None:
        """Start over with a fresh noise generator."""

    def scan(self, s: Samples, stamp_ns: np.ndarray) -> list[Message]:
        """A message for each sample of ``s``, stamped ``stamp_ns`` [ns] (n,)."""
