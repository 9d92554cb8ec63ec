"""Pieces shared by the planar models: longitudinal forces, kinematic lateral motion, blending."""

from __future__ import annotations

import math

from numba import njit

from vilma.vehicle.state import VX, VY, YAW, YAW_RATE

V_SIGN = 0.1
"""Speed [m/s] over which brakes and rolling resistance reverse smoothly (tanh), so standstill is smooth."""


@njit(cache=True, error_model="numpy")
def longitudinal_forces(vx, drive, brake, p):
    """Axle forces along the wheels and resistance along the body.

    Drive [N] is limited by the engine force, by the power ``p_max / |vx|``
    and, per axle, with the brake by friction ``mu * Fz``. Brakes and rolling
    resistance oppose the motion (smooth sign). Returns
    ``(Fx_front, Fx_rear, resistance)`` [N]; resistance is drag
    ``k_drag vx |vx|`` plus rolling.
    """
    f = min(max(drive, -p.fd_max), p.fd_max)
    f_power = p.p_max / max(abs(vx), 1e-3)
    f = min(max(f, -f_power), f_power)
    b = min(max(brake, 0.0), p.fb_max) * math.tanh(vx / V_SIGN)
    fxf = p.split_d * f - p.split_b * b
    fxr = (1.0 - p.split_d) * f - (1.0 - p.split_b) * b
    lim_f, lim_r = p.mu * p.fzf, p.mu * p.fzr
    fxf = min(max(fxf, -lim_f), lim_f)
    fxr = min(max(fxr, -lim_r), lim_r)
    resist = p.k_drag * vx * abs(vx) + p.f_roll * math.tanh(vx / V_SIGN)
    return fxf, fxr, resist


@njit(cache=True, error_model="numpy")
def held(u):
    """The actuator outputs ``u = (steer, drive, brake)`` as the models take them, held over a step: followed by
    the steering's cosine, sine and tangent, computed once a step rather than at each derivative."""
    steer = u[0]
    return steer, u[1], u[2], math.cos(steer), math.sin(steer), math.tan(steer)


@njit(cache=True, error_model="numpy")
def kinematic_lateral(vx, tan_steer, p):
    """Lateral velocity [m/s] and yaw rate [rad/s] of the kinematic bicycle (rear axle rolls without slip) at the
    steering's tangent ``tan_steer``."""
    r = vx * tan_steer / (p.lf + p.lr)
    return p.lr * r, r


@njit(cache=True, error_model="numpy")
def blend_weight(vx, p):
    """Share of the dynamic model: 0 below ``v_lo``, 1 above ``v_hi``, smoothstep between."""
    s = (abs(vx) - p.v_lo) / (p.v_hi - p.v_lo)
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


@njit(cache=True, error_model="numpy")
def planar_motion(x, vy, r, ax, ay_dyn, dr_dyn, tan_steer, w, p):
    """Derivative of ``x`` (a 6-tuple, as the result) given effective lateral velocity and yaw rate.

    ``ax`` is dvx/dt; ``ay_dyn``, ``dr_dyn`` the dynamic dvy/dt and dr/dt.
    The kinematic part follows d/dt of :func:`kinematic_lateral` at fixed
    steering (of tangent ``tan_steer``: the steering is held over a step).
    """
    c, s = math.cos(x[YAW]), math.sin(x[YAW])
    dr_kin = ax * tan_steer / (p.lf + p.lr)
    return (x[VX] * c - vy * s, x[VX] * s + vy * c, r, ax,
            w * ay_dyn + (1.0 - w) * p.lr * dr_kin, w * dr_dyn + (1.0 - w) * dr_kin)


@njit(cache=True, error_model="numpy")
def constrain_lateral(x, tan_steer, w, p):
    """Blend the lateral states toward the kinematic ones by ``1 - w`` (applied after each step; the steering's
    tangent ``tan_steer``)."""
    vy_k, r_k = kinematic_lateral(x[VX], tan_steer, p)
    return (x[0], x[1], x[YAW], x[VX], w * x[VY] + (1.0 - w) * vy_k, w * x[YAW_RATE] + (1.0 - w) * r_k)
