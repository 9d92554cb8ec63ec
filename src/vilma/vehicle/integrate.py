"""Integrators and the compiled plant loop.

The vehicle state is integrated with RK4 (default) or explicit Euler while
the actuator outputs are held over the step; the actuators advance first,
exactly, toward the command's targets. :func:`advance` runs many steps in
compiled code and records the plant at chosen steps for the sensors.

:func:`derivative`, :func:`rk4` and :func:`constrain` are inlined into their callers (numba's ``inline``): each call
between compiled functions copies the plant's 30 constants, and the two calls a derivative took cost a fifth of it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from vilma.vehicle.actuators import actuator_step, targets
from vilma.vehicle.models import held, kinematic, kinematic_constrain, single_track, single_track_constrain
from vilma.vehicle.state import NX, NZ

KINEMATIC, SINGLE_TRACK = 0, 1
"""Model ids (see :data:`vilma.vehicle.models.MODELS`)."""
RK4, EULER = 0, 1
"""Integrator ids."""
INTEGRATORS = ("rk4", "euler")


@njit(cache=True, inline="always")
def derivative(model, x, u, p):
    """dx/dt of model ``model`` (an id); ``u`` the held actuator outputs (:func:`~vilma.vehicle.models.held`)."""
    if model == KINEMATIC:
        return kinematic(x, u, p)
    return single_track(x, u, p)


@njit(cache=True, inline="always")
def constrain(model, x, u, p):
    """Model-specific projection applied after each step (``u`` as in :func:`derivative`)."""
    if model == KINEMATIC:
        return kinematic_constrain(x, u, p)
    return single_track_constrain(x, u, p)


@njit(cache=True)
def constrain_start(model, z, p):
    """The plant vector ``z`` with its lateral states as the model fixes them (:func:`constrain` of its actuator
    outputs held), in place: a drive's start (one compiled call, not one for each of the two)."""
    x = constrain(model, (z[0], z[1], z[2], z[3], z[4], z[5]), held(z[NX:]), p)
    for k in range(NX):
        z[k] = x[k]


@njit(cache=True)
def axpy(x, a, k):
    """``x + a k`` for 6-tuples (states stay tuples in compiled code: no allocation)."""
    return (x[0] + a * k[0], x[1] + a * k[1], x[2] + a * k[2], x[3] + a * k[3], x[4] + a * k[4], x[5] + a * k[5])


@njit(cache=True, inline="always")
def sampled(tick, periods):
    """Whether a sensor samples at ``tick``: a multiple of one of ``periods`` [ticks]."""
    for p in periods:  # noqa: SIM110 (compiled: a loop, not a generator)
        if tick % p == 0:
            return True
    return False


@njit(cache=True, inline="always")
def rk4(model, x, u, p, dt):
    """One classical Runge-Kutta step of length ``dt`` [s] with ``u`` held; ``x`` a 6-tuple."""
    k1 = derivative(model, x, u, p)
    k2 = derivative(model, axpy(x, 0.5 * dt, k1), u, p)
    k3 = derivative(model, axpy(x, 0.5 * dt, k2), u, p)
    k4 = derivative(model, axpy(x, dt, k3), u, p)
    return (x[0] + dt / 6.0 * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
            x[1] + dt / 6.0 * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
            x[2] + dt / 6.0 * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
            x[3] + dt / 6.0 * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
            x[4] + dt / 6.0 * (k1[4] + 2.0 * k2[4] + 2.0 * k3[4] + k4[4]),
            x[5] + dt / 6.0 * (k1[5] + 2.0 * k2[5] + 2.0 * k3[5] + k4[5]))


@njit(cache=True)
def euler(model, x, u, p, dt):
    """One explicit Euler step of length ``dt`` [s] with ``u`` held; ``x`` a 6-tuple."""
    return axpy(x, dt, derivative(model, x, u, p))


@njit(cache=True)
def advance(model, integrator, z, mode, cmd, p, dt, n, tick, periods, out_z, out_dx, out_tick):
    """Run ``n`` physics steps of ``dt`` [s] on the plant vector ``z`` (updated in place).

    ``mode``/``cmd`` are the longitudinal mode id and ``(steer, drive, brake,
    velocity_limit)``, held for all ``n`` steps; ``tick`` is the clock tick
    before the first step. After each step whose tick is a multiple of one
    of ``periods`` [ticks] (the sensors' sample ticks), the tick, the plant
    vector and its derivative go to the next row of ``out_tick``, ``out_z``
    and ``out_dx``. Returns the number of rows written.
    """
    x = (z[0], z[1], z[2], z[3], z[4], z[5])
    u = z[NX:]  # the actuators advance in place (a copy would be a heap allocation a call)
    j = 0
    for i in range(1, n + 1):
        steer, drive, brake = targets(mode, cmd, x, u, p)
        actuator_step(u, steer, drive, brake, p, dt)
        v = held(u)
        x = rk4(model, x, v, p, dt) if integrator == RK4 else euler(model, x, v, p, dt)
        x = constrain(model, x, v, p)
        if sampled(tick + i, periods):
            dx = derivative(model, x, v, p)
            for k in range(NX):
                out_z[j, k] = x[k]
                out_dx[j, k] = dx[k]
            for k in range(NX, NZ):  # element by element: a slice copy compiles its shape check's message
                out_z[j, k] = u[k - NX]
            out_tick[j] = tick + i
            j += 1
    for k in range(NX):
        z[k] = x[k]
    return j


def empty_records(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Output arrays ``(out_z, out_dx, out_tick)`` of :func:`advance` for up to ``n`` samples."""
    return np.empty((n, NZ)), np.empty((n, NX)), np.empty(n, dtype=np.int64)
