"""Objects: the true obstacles near the car, for controllers that want ground truth (with seeded noise)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from vilma.core.messages import Message, ObjectList, ObjectState
from vilma.sensors.base import Samples
from vilma.sensors.noise import standard_normals
from vilma.sensors.scene import Scene
from vilma.vehicle.state import X as CAR_X
from vilma.vehicle.state import Y as CAR_Y
from vilma.world.states import V, X, Y, states_at


@dataclass(frozen=True, slots=True, kw_only=True)
class ObjectsParams:
    """The objects sensor."""

    rate_hz: float = 10.0
    """Rate of the object lists [Hz]."""
    range: float = 50.0
    """Reach [m]: the objects whose reference point lies within this distance of the car's centre of mass."""
    position_noise: float = 0.1
    """Standard deviation of each object's x and y [m]."""
    speed_noise: float = 0.1
    """Standard deviation of each object's speed [m/s]."""

    def __post_init__(self) -> None:
        for name in ("rate_hz", "range"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"objects {name} must be a positive number, got {getattr(self, name)!r}")
        for name in ("position_noise", "speed_noise"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"objects {name} must be a number >= 0, got {getattr(self, name)!r}")


@njit(cache=True)
def _near(rows, z, t, states, present, static, dt, ring, reach, out, keep):
    """The obstacles' states at the samples ``rows`` of ``z`` at obstacle times ``t`` [s] into ``out`` (n, m, 4),
    and whether each is present within ``reach`` [m] of the car into ``keep`` (n, m)."""
    for k in range(rows.shape[0]):
        states_at(states, present, static, dt, t[k], out[k], keep[k], ring)
        for n in range(states.shape[0]):
            keep[k, n] &= math.hypot(out[k, n, X] - z[rows[k], CAR_X], out[k, n, Y] - z[rows[k], CAR_Y]) <= reach


class ObjectsSensor:
    """The scene's objects within :attr:`ObjectsParams.range`, on ``objects``: id, position and speed with
    Gaussian noise, orientation, length and width exact (:class:`~vilma.core.messages.ObjectList`)."""

    name = topic = "objects"

    def __init__(self, params: ObjectsParams, scene: Scene) -> None:
        self.params, self.rate_hz, self.scene = params, params.rate_hz, scene
        self._size = scene.size.tolist()
        self._sigma = np.array([params.position_noise, params.position_noise, params.speed_noise])

    def reset(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def scan(self, s: Samples, stamp_ns: np.ndarray) -> list[Message]:
        sc, n, m = self.scene, len(s), len(self.scene.ids)
        states, keep = np.empty((n, m, 4)), np.empty((n, m), bool)
        _near(s.rows, s.z, sc.times(stamp_ns), sc.states, sc.present, sc.static, sc.dt, sc.ring, self.params.range,
              states, keep)
        # noise for every obstacle, seen or not: a sample's draws do not depend on which are near
        states[..., [X, Y, V]] += self._sigma * standard_normals(self.rng, n * m, 3).reshape(n, m, 3)
        ids = sc.ids.tolist()
        return [ObjectList(stamp_ns=t, objects=[ObjectState(ids[j], *states[k, j].tolist(), *self._size[j])
                                                for j in np.flatnonzero(keep[k]).tolist()])
                for k, t in enumerate(stamp_ns.tolist())]
