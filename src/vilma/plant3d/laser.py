"""A laser scanner on the car: rays cast from a mount on the chassis into the MuJoCo world, as MORSE's SICK.

The rays see every geom but the car's own (:func:`~vilma.plant3d.car_model.car_xml` puts those in a geom group
of their own). MuJoCo is imported by :meth:`LaserSensor.capture`, so the parameters import without it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vilma.core.messages import Message, PointCloud
from vilma.plant3d.capture import all_finite, check_mount

if TYPE_CHECKING:
    import mujoco

    from vilma.plant3d.plant import MujocoPlant

GEOM_GROUPS = 6
"""Number of MuJoCo geom groups a ray can select."""
MAX_RAYS = 300_000
"""Most rays a scan casts, over all layers: a 64-layer Velodyne HDL-64E measures about 288,000 points a turn."""


@dataclass(frozen=True, slots=True, kw_only=True)
class LaserParams:
    """A scanning laser range finder fixed to the chassis (MORSE's SICK: 180 deg, 1 deg, 30 m, one layer)."""

    name: str = "laser"
    """Frame name (a word); the scans go out on topic ``laser``."""
    position: tuple[float, float, float] = (1.9, 0.0, -0.3)
    """Mount in the body frame from the centre of mass [m]; the default is on the front bumper of vilma's car,
    5 cm ahead of its body and 0.49 m above the ground at rest, under the bonnet: low enough to see cones."""
    yaw: float = 0.0
    """Heading of the scan's centre from body x, counter-clockwise [rad]."""
    fov: float = 180.0
    """Angle the rays of a layer span [deg], a whole number of ``resolution`` steps."""
    resolution: float = 1.0
    """Angle between neighbouring rays of a layer [deg]."""
    layers: tuple[float, ...] = (0.0,)
    """Elevation of each layer above the mount's horizontal plane [deg]; one layer is a 2D scanner."""
    min_range: float = 0.1
    """Nearer hits are not reported [m]."""
    max_range: float = 30.0
    """Farther hits are not reported [m]."""
    rate_hz: float = 10.0
    """Scan rate [Hz]."""
    range_noise: float = 0.0
    """Standard deviation of each range [m], Gaussian (the flat-ground laser only; the 3D plant's is exact)."""

    def __post_init__(self) -> None:
        what = check_mount("laser", self.name, self.position, self.yaw)
        if not (all_finite(self.fov) and 0 < self.fov <= 360):
            raise ValueError(f"{what} fov must be in (0, 360] deg, got {self.fov!r}")
        if not (all_finite(self.resolution) and 0 < self.resolution <= self.fov):
            raise ValueError(f"{what} resolution must be in (0, fov] deg, got {self.resolution!r}")
        steps = self.fov / self.resolution
        if abs(steps - round(steps)) > 1e-6 * steps:
            raise ValueError(f"{what} fov ({self.fov!r} deg) must be a whole number of resolution steps "
                             f"({self.resolution!r} deg): change either")
        if not (isinstance(self.layers, tuple) and self.layers and all_finite(*self.layers)
                and all(-90 <= e <= 90 for e in self.layers)):
            raise ValueError(f"{what} layers must be a non-empty tuple of elevations in [-90, 90] deg, "
                             f"got {self.layers!r}")
        if steps * len(self.layers) > MAX_RAYS:
            raise ValueError(f"{what} casts {steps * len(self.layers):.3g} rays a scan ({steps:g} a layer), more than "
                             f"{MAX_RAYS}: give a coarser resolution or fewer layers")
        if not (all_finite(self.min_range, self.max_range) and 0 <= self.min_range < self.max_range):
            raise ValueError(f"{what} ranges must satisfy 0 <= min_range < max_range [m], "
                             f"got {self.min_range!r}, {self.max_range!r}")
        if not (all_finite(self.rate_hz) and self.rate_hz > 0):
            raise ValueError(f"{what} rate_hz must be a positive number [Hz], got {self.rate_hz!r}")
        if not (all_finite(self.range_noise) and self.range_noise >= 0):
            raise ValueError(f"{what} range_noise must be a number >= 0 [m], got {self.range_noise!r}")

    @property
    def bearings(self) -> np.ndarray:
        """Bearing of each ray of a layer from the scan's centre, counter-clockwise [rad], ``(n,)``: from
        ``-fov / 2`` in ``resolution`` steps to ``+fov / 2`` (without repeating -180 deg in a full circle)."""
        steps = round(self.fov / self.resolution)
        count = steps if self.fov == 360 else steps + 1
        return np.radians(-self.fov / 2 + self.resolution * np.arange(count))

    def directions(self) -> np.ndarray:
        """Unit ray vectors in the laser frame (x forward, y left, z up), ``(layers * bearings, 3)``, in scan
        order: by layer, then by bearing."""
        bearing = self.bearings[None, :]
        elevation = np.radians(np.array(self.layers))[:, None]
        rays = np.stack(np.broadcast_arrays(np.cos(elevation) * np.cos(bearing), np.cos(elevation) * np.sin(bearing),
                                            np.sin(elevation)), axis=-1)
        return rays.reshape(-1, 3)


class LaserSensor:
    """A :class:`~vilma.plant3d.capture.WorldSensor` publishing a :class:`~vilma.core.messages.PointCloud` on
    ``laser`` each scan: one range per ray (inf: nothing within ``min_range .. max_range``), the hits as points."""

    def __init__(self, params: LaserParams) -> None:
        self.params = params
        self.name = params.name
        self.rate_hz = params.rate_hz
        self._rays = params.directions()
        self._plant: MujocoPlant | None = None

    def mjcf(self) -> str:
        """A ``<site>`` named :attr:`name` at the mount, x along the scan's centre (in group 4, which viewers and
        cameras hide by default)."""
        p = self.params
        c, s = math.cos(p.yaw), math.sin(p.yaw)
        return (f'<site name="{p.name}" pos="{" ".join(f"{v:.9g}" for v in p.position)}" '
                f'xyaxes="{c:.9g} {s:.9g} 0 {-s:.9g} {c:.9g} 0" size="0.03" group="4"/>')

    def attach(self, plant: MujocoPlant) -> None:
        """Find the mount and the geom groups to see (those without the car's geoms) in ``plant``'s model."""
        m = plant.model
        self._site = m.site(self.name).id
        self._groups = _world_groups(m)
        n = len(self._rays)
        self._vec = np.empty((n, 3))
        self._dist = np.empty(n)
        self._geom = np.empty(n, np.int32)
        self._plant = plant

    def capture(self, stamp_ns: int) -> dict[str, Message]:
        """Cast every ray from the mount's pose in the plant's data (as
        :meth:`CameraSensor.capture <vilma.plant3d.camera.CameraSensor.capture>`: at the end of the last step)."""
        import mujoco

        if self._plant is None:
            raise RuntimeError(f"laser {self.name!r} captured before attach(plant)")
        p, m, d = self.params, self._plant.model, self._plant.data
        np.matmul(self._rays, d.site_xmat[self._site].reshape(3, 3).T, out=self._vec)
        mujoco.mj_multiRay(m, d, d.site_xpos[self._site], self._vec.reshape(-1), self._groups, True, -1,
                           self._geom, self._dist, None, len(self._rays), p.max_range)
        ranges = self._dist.astype(np.dtype("<f4"))
        ranges[(self._geom < 0) | (self._dist < p.min_range) | (self._dist > p.max_range)] = np.inf
        hit = np.isfinite(ranges)
        points = (self._rays[hit] * ranges[hit, None]).astype(np.dtype("<f4"))
        return {"laser": PointCloud(stamp_ns=stamp_ns, frame_id=self.name, points=points.tobytes(),
                                    ranges=ranges.tobytes())}

    def close(self) -> None:
        """Forget the plant (the laser holds no other resources)."""
        self._plant = None


def _world_groups(model: mujoco.MjModel) -> np.ndarray:
    """Mask of the geom groups a ray sees, ``(6,)`` uint8: those holding none of the car's geoms (the geoms of
    the chassis's tree). Raises ``ValueError`` when a group holds geoms of both the car and the world."""
    chassis = model.body("chassis").id
    car = model.body_rootid[model.geom_bodyid] == model.body_rootid[chassis]
    car_groups, world_groups = set(model.geom_group[car].tolist()), set(model.geom_group[~car].tolist())
    if car_groups & world_groups:
        raise ValueError(f"the laser cannot see past the car: geom groups {sorted(car_groups & world_groups)} hold "
                         "both the car's geoms and the world's; give the car's geoms a group of their own")
    return np.array([g not in car_groups for g in range(GEOM_GROUPS)], np.uint8)
