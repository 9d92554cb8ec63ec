"""Dynamic single-track (bicycle) model with saturating tyres.

Body-frame equations at the centre of mass (Rajamani, *Vehicle Dynamics and
Control*, 2nd ed., sec. 2.3, with the front forces rotated by the wheel angle)::

    m (dvx/dt - r vy) = Fxf cos d - Fyf sin d + Fxr - resistance
    m (dvy/dt + r vx) = Fxf sin d + Fyf cos d + Fyr
    Iz dr/dt          = lf (Fxf sin d + Fyf cos d) - lr Fyr

Lateral tyre force, simplified Pacejka magic formula per axle::

    Fy = -D sin(C atan(B a - E (B a - atan(B a)))),  D = sqrt((mu Fz)^2 - Fx^2)

with ``B = C_alpha / (C mu Fz)`` so the initial slope is the cornering
stiffness, and slip angle ``a = atan(v_lateral / |v_longitudinal|)`` in each
wheel's frame, which stays valid in reverse and at full lock. Below
``blend_speed_low`` the lateral motion is kinematic, above
``blend_speed_high`` dynamic, blended between (nothing divides by a speed
near zero). The blend of the lateral states is applied once per step, so
only inside that speed band does the result depend slightly on the step.
"""

from __future__ import annotations

import math

from numba import njit

from vilma.vehicle.models.common import (
    blend_weight,
    constrain_lateral,
    kinematic_lateral,
    longitudinal_forces,
    planar_motion,
)
from vilma.vehicle.state import VX, VY, YAW_RATE


@njit(cache=True, error_model="numpy")
def lateral_tyre_force(alpha, fx, fz, c_alpha, p):
    """Axle lateral force [N] at slip angle ``alpha`` [rad] with longitudinal force ``fx`` [N] (friction ellipse)."""
    d_full = p.mu * fz
    b = c_alpha / (p.shape * d_full)
    d = math.sqrt(max(d_full * d_full - fx * fx, 0.0))
    ba = b * alpha
    if p.curv != 0.0:  # E = 0 (both presets) makes the term exactly 0: an atan of a derivative's 12 saved
        ba -= p.curv * (ba - math.atan(ba))
    return -d * math.sin(p.shape * math.atan(ba))


@njit(cache=True, error_model="numpy")
def single_track(x, u, p):
    """dx/dt of the blended single-track model. ``u`` the held actuator outputs (:func:`~.common.held`)."""
    vx = x[VX]
    w = blend_weight(vx, p)
    vy_k, r_k = kinematic_lateral(vx, u[5], p)
    vy = w * x[VY] + (1.0 - w) * vy_k
    r = w * x[YAW_RATE] + (1.0 - w) * r_k
    fxf, fxr, resist = longitudinal_forces(vx, u[1], u[2], p)
    c, s = u[3], u[4]
    vf_lat = vy + p.lf * r
    alpha_f = math.atan2(-vx * s + vf_lat * c, abs(vx * c + vf_lat * s))
    alpha_r = math.atan2(vy - p.lr * r, abs(vx))
    fyf = lateral_tyre_force(alpha_f, fxf, p.fzf, p.cf, p)
    fyr = lateral_tyre_force(alpha_r, fxr, p.fzr, p.cr, p)
    f_front_lat = fxf * s + fyf * c
    ax_dyn = (fxf * c - fyf * s + fxr - resist) / p.m + r * vy
    ax_kin = (fxf + fxr - resist) / p.m
    ay_dyn = (f_front_lat + fyr) / p.m - r * vx
    dr_dyn = (p.lf * f_front_lat - p.lr * fyr) / p.iz
    return planar_motion(x, vy, r, w * ax_dyn + (1.0 - w) * ax_kin, ay_dyn, dr_dyn, u[5], w, p)


@njit(cache=True, error_model="numpy")
def single_track_constrain(x, u, p):
    """Blend the lateral states toward the kinematic ones at low speed (after each step)."""
    return constrain_lateral(x, u[5], blend_weight(x[VX], p), p)
