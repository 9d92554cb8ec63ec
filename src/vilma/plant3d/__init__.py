"""The 3D plant: vilma's car in MuJoCo, with suspension, load transfer, roll and pitch, and a world to drive in.

:func:`car_xml` builds the MJCF model from :class:`~vilma.vehicle.params.VehicleParams`;
:class:`MujocoPlant` steps it with vilma's actuator outputs (steer, drive force, brake force).
"""

from vilma.plant3d.car_model import Box, World, car_xml
from vilma.plant3d.plant import MujocoPlant

__all__ = ["Box", "MujocoPlant", "World", "car_xml"]
