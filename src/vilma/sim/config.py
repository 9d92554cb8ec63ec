"""The settings of a simulation run: :class:`SimConfig`, checked when made."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from vilma.plant3d.camera import CameraParams
from vilma.plant3d.laser import LaserParams
from vilma.plant3d.world import World
from vilma.sensors import SensorSuite
from vilma.sensors.laser import PlanarLaser
from vilma.sensors.objects import ObjectsParams, ObjectsSensor
from vilma.sensors.scene import Scene, SceneSensor
from vilma.vehicle import models
from vilma.vehicle.integrate import INTEGRATORS
from vilma.vehicle.params import VehicleParams, vilma
from vilma.vehicle.state import VehicleState

if TYPE_CHECKING:  # the roads extra
    from vilma.world.reactive import ReactiveTraffic
    from vilma.world.road_view import LaneletLines
    from vilma.world.traffic import Traffic

MUJOCO = "mujoco"
"""The 3D plant's model name."""


@dataclass(frozen=True, slots=True, kw_only=True)
class SimConfig:
    """Everything that defines a simulation run."""

    vehicle: VehicleParams = field(default_factory=vilma)
    model: str = "single_track"
    """Plant model: one of :data:`vilma.vehicle.models.MODELS`, or ``mujoco`` (the 3D plant,
    :mod:`vilma.plant3d`: suspension, roll and pitch; slower)."""
    integrator: str = "rk4"
    """``rk4`` or ``euler``."""
    step: float = 0.01
    """Physics step [s]; at most 10 ms (RK4 is accurate and stable at 10 ms down to standstill), at least 0.1 ms
    (finer only costs time: a day of sim time is already 864 million steps)."""
    sensors: SensorSuite = SensorSuite()
    watchdog_timeout: float = 0.5
    """While autonomous, stop the car when no command came for this long [s] (0: off)."""
    seed: int = 0
    """Seed of every noise generator."""
    initial: VehicleState = VehicleState()
    world: World = World()
    """Ramps, bumps and obstacles (ramps and bumps on the 3D plant only); on flat ground its boxes and cones are the
    ``traffic`` (:meth:`~vilma.plant3d.world.World.traffic`, which :func:`~vilma.scenario.simulation.read_sim` gives
    it)."""
    cameras: tuple[CameraParams, ...] = ()
    """Cameras on the car (the 3D plant only), e.g. :func:`~vilma.plant3d.camera.stereo_pair`."""
    laser: LaserParams | None = None
    """A laser scanner on the car: in the 3D plant, it sees the MuJoCo world; on flat ground, a planar one (one
    layer) sees the ``traffic``."""
    objects: ObjectsParams | None = None
    """The objects sensor: the ``traffic`` near the car."""
    traffic: Traffic | None = field(default=None, compare=False, repr=False)
    """The obstacles of a CommonRoad scenario, which the flat-ground laser and the objects sensor see."""
    traffic_t0: float = 0.0
    """The traffic's time at sim time 0 [s] from its time step 0 (the planning problem's initial step)."""
    reactive: ReactiveTraffic | None = field(default=None, compare=False, repr=False)
    """Reactive traffic (its :attr:`~vilma.world.reactive.ReactiveTraffic.traffic` is then ``traffic``, from
    ``traffic_t0`` 0): the simulator steps it at each of its periods, restarts it on :meth:`Simulator.reset`."""
    road: tuple[LaneletLines, ...] = field(default=(), compare=False, repr=False)
    """The lanelets of a CommonRoad scenario, which the 3D plant draws on its ground (and its traffic moves on)."""

    def __post_init__(self) -> None:
        if self.model not in (*models.MODELS, MUJOCO):
            raise ValueError(f"unknown model {self.model!r}; use one of {', '.join(models.MODELS)}, {MUJOCO}")
        for what, present in (("a world with ramps or bumps needs", bool(self.world.ramps or self.world.bumps)),
                              ("cameras need", bool(self.cameras))):
            if present and self.model != MUJOCO:
                raise ValueError(f"{what} the 3D plant (model {MUJOCO}), not {self.model}")
        if self.laser is not None and self.model == MUJOCO and self.laser.range_noise:
            raise ValueError(f"the 3D plant's laser is exact: remove the laser's range_noise "
                             f"({self.laser.range_noise!r} m), or drive on flat ground")
        if self.laser is not None and self.model != MUJOCO and self.laser.layers != (0.0,):
            raise ValueError(f"a laser on flat ground ({self.model}) scans one layer: give layers: [0], or plant: "
                             f"{MUJOCO}")
        names = [c.name for c in self.cameras] + ([self.laser.name] if self.laser is not None else [])
        if len(set(names)) != len(names):
            raise ValueError(f"camera and laser names must differ, got {', '.join(names)}")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"unknown integrator {self.integrator!r}; use one of {', '.join(INTEGRATORS)}")
        if not 1e-4 <= self.step <= 0.01:
            raise ValueError(f"physics step must be in [0.0001, 0.01] s, got {self.step!r}")
        if not self.watchdog_timeout >= 0:
            raise ValueError(f"watchdog_timeout must be >= 0 s, got {self.watchdog_timeout!r}")

    @property
    def world_sensors(self) -> tuple[CameraParams | LaserParams, ...]:
        """The parameters of the cameras and the laser."""
        return (*self.cameras, *([self.laser] if self.laser is not None else []))

    @property
    def world_topics(self) -> tuple[str, ...]:
        """Topic names of the world sensors (``camera/<name>``, ``camera/<name>/depth``, ``laser``)."""
        out = []
        for c in self.cameras:
            out += [f"camera/{c.name}", *([f"camera/{c.name}/depth"] if c.depth else [])]
        return (*out, *(["laser"] if self.laser is not None else []))

    def scene_sensors(self) -> list[SceneSensor]:
        """The sensors of the ``traffic`` (the planar laser on flat ground, the objects sensor), in a fixed order."""
        scene, out = Scene.of(self.traffic, self.traffic_t0), []
        if self.laser is not None and self.model != MUJOCO:
            p = self.laser
            out.append(PlanarLaser(name=p.name, mount=(*p.position[:2], p.yaw), bearings=p.bearings,
                                   min_range=p.min_range, max_range=p.max_range, noise=p.range_noise, rate_hz=p.rate_hz,
                                   scene=scene))
        if self.objects is not None:
            out.append(ObjectsSensor(self.objects, scene))
        return out
