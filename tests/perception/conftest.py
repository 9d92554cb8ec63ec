"""Scans for the perception tests, made by vilma's own planar laser on boxes in a flat world."""

from __future__ import annotations

import numpy as np

from vilma.plant3d.laser import LaserParams
from vilma.sensors.base import Samples, sensor_rng
from vilma.sensors.laser import PlanarLaser
from vilma.sensors.scene import Scene
from vilma.vehicle.state import VehicleState

SICK = LaserParams(fov=270.0, resolution=0.25, max_range=40.0)
"""A SICK LMS: 1081 rays over 270 deg, 0.25 deg apart."""


def outline(length: float, width: float) -> np.ndarray:
    """A box's outline in its own frame, counter-clockwise (4, 2) [m]."""
    return np.array([[length, -width], [length, width], [-length, width], [-length, -width]]) / 2


def boxes(poses, sizes, dt: float = 0.1) -> Scene:
    """Boxes of ``sizes`` (m, 2) (length, width) [m] at ``poses`` (m, k, 3 or 4) (x, y, yaw[, speed]) at the time
    steps 0, dt, 2 dt ... (one step: standing still)."""
    poses = np.asarray(poses, float)
    states = np.zeros((*poses.shape[:2], 4))
    states[..., : poses.shape[2]] = poses
    m, k = states.shape[:2]
    return Scene(np.arange(1, m + 1), np.full(m, k == 1), np.stack([outline(*s) for s in sizes]), states,
                 np.ones((m, k), bool), dt)


def scan(scene: Scene, car: VehicleState = VehicleState(), stamp_ns: int = 0, laser: LaserParams = SICK
         ) -> np.ndarray:
    """The ranges [m] of one scan of ``scene`` by ``laser`` on ``car`` at sim time ``stamp_ns`` [ns] (inf: no
    return)."""
    sensor = PlanarLaser(name="laser", mount=(*laser.position[:2], laser.yaw), bearings=laser.bearings,
                         min_range=laser.min_range, max_range=laser.max_range, noise=laser.range_noise,
                         rate_hz=laser.rate_hz, scene=scene)
    sensor.reset(sensor_rng(stamp_ns, "laser"))
    (msg,) = sensor.scan(Samples(np.zeros(1, np.int64), car.to_array()[None], np.zeros((1, 6))), np.array([stamp_ns]))
    return np.frombuffer(msg.ranges, "<f4").astype(float)
