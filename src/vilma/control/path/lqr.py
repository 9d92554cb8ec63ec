"""LQR steering: a discrete linear-quadratic regulator on the path errors, with curvature feed-forward.

After PythonRobotics' "LQR steering control" (A. Sakai, PathTracking/lqr_steer_control/lqr_steer_control.py,
github.com/AtsushiSakai/PythonRobotics): the kinematic bicycle linearised about the path, with the error state
``x = [e, de, th_e, dth_e]`` (cross-track error [m], positive left, its rate [m/s], heading error [rad], the
car's heading minus the path's, its rate [rad/s]) and, at the control period ``dt`` and speed ``v``,

    x[k+1] = A x[k] + B u[k],   A = [[1, dt, 0, 0], [0, 0, v, 0], [0, 0, 1, dt], [0, 0, 0, 0]],
                                B = [0, 0, 0, v / L]^T,

``u = -K x`` with ``K`` from the discrete algebraic Riccati equation for the weights ``Q`` (diagonal) and ``R``,
plus the kinematic feed-forward ``atan(L kappa)``. The gain depends on the speed only, so it is tabulated when
the constants are made (scipy's exact DARE solver, every ``speed_resolution`` up to ``max_speed``) and
interpolated in the compiled step. vilma's pose is the centre of mass, so the law acts there, as Stanley's
``cg`` point does: the heading error is measured from the heading the car has when its centre of mass rides the
path in steady cornering, the path's less the sideslip ``atan(lr kappa) - m lf v^2 kappa / (L C_r)``. The
kinematic model has no tyres, so vilma adds, with ``tyre_slip``, the single-track model's steady-state terms
(the rear slip above and the understeer ``K v^2 kappa`` in the feed-forward), without which the car runs wide
at speed; the regulator has no integral action to remove that error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from vilma.control.checks import check_params
from vilma.control.registry import PATH, ControllerType, register
from vilma.core.geometry import wrap
from vilma.trajectory.trajectory import CURVATURE_SPAN, path_curvature_at, path_heading_at, path_project
from vilma.vehicle.params import VehicleParams


@dataclass(frozen=True, slots=True, kw_only=True)
class LqrParams:
    """Weights of the LQR steering controller and its gain table."""

    period: float = 0.02
    """Control period [s], also the step of the discrete model."""
    q_lateral: float = 1.0
    """Weight on the cross-track error [1/m^2]."""
    q_lateral_rate: float = 1.0
    """Weight on the cross-track error's rate [(s/m)^2]."""
    q_heading: float = 1.0
    """Weight on the heading error [1/rad^2]."""
    q_heading_rate: float = 1.0
    """Weight on the heading error's rate [(s/rad)^2]."""
    r_steer: float = 1.0
    """Weight on the steering feedback [1/rad^2]."""
    max_speed: float = 40.0
    """Top of the gain table [m/s]; faster drives use the gain there."""
    speed_resolution: float = 0.5
    """Speed step of the gain table [m/s]; slower drives use the gain at this speed."""
    tyre_slip: bool = True
    """Feed forward the steady-state tyre slip of the single-track model (off for a kinematic plant)."""
    window: int = 40
    """Segments searched on each side of the last projection."""

    def __post_init__(self) -> None:
        check_params(self, "lqr", positive=("q_lateral", "r_steer", "max_speed", "speed_resolution"))
        if self.speed_resolution > self.max_speed:
            raise ValueError(f"lqr speed_resolution {self.speed_resolution!r} must be <= max_speed "
                             f"{self.max_speed!r}")


class LqrConsts(NamedTuple):
    """:class:`LqrParams`, the car's geometry and the gain table as compiled code reads them."""

    period: float
    speeds: np.ndarray
    """Speeds of the gain table [m/s], (n,)."""
    gains: np.ndarray
    """The gain ``K`` at each speed, (4, n): row ``j`` multiplies error ``j`` of ``[e, de, th_e, dth_e]``."""
    window: int
    cg_to_rear: float
    wheelbase: float
    max_steer: float
    understeer: float
    """Steering added per (m/s)^2 of speed and 1/m of curvature: the understeer gradient K [rad s^2/m] (0: no slip)."""
    rear_slip: float
    """Rear tyre slip per (m/s)^2 and 1/m: m lf / (L C_r) [rad s^2/m], which turns the car's heading out (0: none)."""


RESET = (-1.0, math.nan, math.nan)
"""The state after a reset: ``[segment of the last projection (-1: none), previous e [m], previous th_e [rad]]``
(NaN: none yet)."""


def lqr_gain(speed: float, period: float, wheelbase: float, q: np.ndarray, r: float) -> np.ndarray:
    """The LQR gain ``K`` (4,) of the error model at ``speed`` > 0 [m/s] and ``period`` [s], weights ``q`` (4,)."""
    a = np.array([[1.0, period, 0.0, 0.0], [0.0, 0.0, speed, 0.0], [0.0, 0.0, 1.0, period], [0.0, 0.0, 0.0, 0.0]])
    b = np.array([[0.0], [0.0], [0.0], [speed / wheelbase]])
    import scipy.linalg  # 0.1 s to import: only for the LQR's constants, not whenever the registry lists it

    x = scipy.linalg.solve_discrete_are(a, b, np.diag(q), np.array([[r]]))
    return np.linalg.solve(b.T @ x @ b + r, b.T @ x @ a)[0]


def lqr_consts(params: LqrParams, vehicle: VehicleParams) -> LqrConsts:
    """The compiled constants: ``params`` with ``vehicle``'s geometry and the gains tabulated over speed."""
    p, v = params, vehicle
    q = np.array([p.q_lateral, p.q_lateral_rate, p.q_heading, p.q_heading_rate])
    speeds = p.speed_resolution * np.arange(1, math.floor(p.max_speed / p.speed_resolution) + 1)
    gains = np.array([lqr_gain(speed, p.period, v.wheelbase, q, p.r_steer) for speed in speeds]).T.copy()
    slip = 1.0 if p.tyre_slip else 0.0
    rear_slip = v.mass * v.cg_to_front / (v.wheelbase * v.cornering_stiffness_rear)
    return LqrConsts(p.period, speeds, gains, p.window, v.cg_to_rear, v.wheelbase, v.max_steer,
                     slip * v.understeer_gradient, slip * rear_slip)


@njit(cache=True)
def lqr_step(c, state, pa, x, y, yaw, speed, yaw_rate):
    """One period at the centre of mass ``(x, y, yaw)``, ``speed`` [m/s]: (steer [rad], passed the path's end).

    ``yaw_rate`` [rad/s] is unused: the model's rates are the errors' differences over the period.
    """
    i, _, s, e, _, _, _, left = path_project(pa, x, y, int(state[0]), c.window)
    kappa = path_curvature_at(pa, s, CURVATURE_SPAN)
    v2k = speed * speed * kappa
    th_e = wrap(yaw + math.atan(c.cg_to_rear * kappa) - c.rear_slip * v2k - path_heading_at(pa, s, 1.0))
    first = math.isnan(state[1])  # no rates on the first period: zero rather than a jump from nothing
    de = 0.0 if first else (e - state[1]) / c.period
    dth_e = 0.0 if first else wrap(th_e - state[2]) / c.period
    state[0], state[1], state[2] = i, e, th_e
    v, g = abs(speed), c.gains  # the table's gains, linear between its speeds, clamped to its ends
    feedback = (np.interp(v, c.speeds, g[0]) * e + np.interp(v, c.speeds, g[1]) * de
                + np.interp(v, c.speeds, g[2]) * th_e + np.interp(v, c.speeds, g[3]) * dth_e)
    steer = math.atan(c.wheelbase * kappa) + c.understeer * v2k - feedback
    return min(max(steer, -c.max_steer), c.max_steer), left <= 0.0


register(ControllerType("lqr", PATH, LqrParams, LqrConsts, lqr_consts, RESET, lqr_step))
