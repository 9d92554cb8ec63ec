"""The 3D plant: vilma's car in MuJoCo, with suspension, load transfer, roll and pitch, and a world to drive in.

:func:`~vilma.plant3d.car_model.car_xml` builds the MJCF model from
:class:`~vilma.vehicle.params.VehicleParams`; :class:`~vilma.plant3d.plant.MujocoPlant` steps it with
vilma's actuator outputs (steer, drive force, brake force). Parameter modules (``world``, ``camera``,
``laser``) import without MuJoCo; ``plant`` imports it.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # MuJoCo picks its GL backend on first import: headless, CPU or GPU
