"""Kinematic bicycle: no tyre slip; the rear axle rolls along the car's heading.

Yaw rate ``r = vx tan(delta) / L``, lateral velocity of the centre of mass
``vy = lr r``; longitudinal ``m dvx/dt = Fx_front + Fx_rear - resistance``
(see :func:`~vilma.vehicle.models.common.longitudinal_forces`). Valid at any
speed where tyres do not slide; exact at parking speeds.
"""

from __future__ import annotations

from numba import njit

from vilma.vehicle.models.common import constrain_lateral, kinematic_lateral, longitudinal_forces, planar_motion
from vilma.vehicle.state import VX


@njit(cache=True, error_model="numpy")
def kinematic(x, u, p):
    """dx/dt of the kinematic bicycle. ``u`` the held actuator outputs (:func:`~.common.held`)."""
    fxf, fxr, resist = longitudinal_forces(x[VX], u[1], u[2], p)
    ax = (fxf + fxr - resist) / p.m
    vy, r = kinematic_lateral(x[VX], u[5], p)
    return planar_motion(x, vy, r, ax, 0.0, 0.0, u[5], 0.0, p)


@njit(cache=True, error_model="numpy")
def kinematic_constrain(x, u, p):
    """Put the lateral states on the kinematic manifold (after each step)."""
    return constrain_lateral(x, u[5], 0.0, p)
