"""Sensors: each turns plant samples into readings at its own rate, with seeded noise.

A sensor is given the plant at its sample ticks as arrays (:class:`Samples`)
and returns one row per sample (:class:`Readings`), so a long run costs a few
vectorised numpy calls, not one Python object per reading. Readings become
typed messages on demand.
"""

from vilma.sensors.base import Readings, Samples, Sensor
from vilma.sensors.suite import SensorSuite, build_sensors

__all__ = ["Readings", "Samples", "Sensor", "SensorSuite", "build_sensors"]
