"""One compiled call a chunk on the planar plant: the physics, then every sensor.

A 20 ms frame is two physics steps and a reading or two of each sensor: the work takes a few microseconds, so
what the call costs is its arguments. They cross as flat arrays: the plant's 30 constants as a tuple cost more
than the whole frame (numba types a named tuple field by field on every call), as an array almost nothing.
"""

from __future__ import annotations

from numba import njit

from vilma.sensors.bank import counts_fit, measure_all
from vilma.vehicle.integrate import advance
from vilma.vehicle.params import PlantConsts


@njit(cache=True)
def consts_of(a):
    """The :class:`~vilma.vehicle.params.PlantConsts` whose fields are the array ``a``, in order."""
    return PlantConsts(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14],
                       a[15], a[16], a[17], a[18], a[19], a[20], a[21], a[22], a[23], a[24], a[25], a[26], a[27],
                       a[28], a[29])


@njit(cache=True)
def run_frame(model, integrator, z, mode, cmd, consts, dt, n, tick, periods, out_z, out_dx, out_tick, step_ns, book,
              noise, outs, stamps, par, vec, axes):
    """:func:`~vilma.vehicle.integrate.advance` with the constants as an array (:func:`consts_of`), then the bank's
    :func:`~vilma.sensors.bank.measure_all`; returns the rows recorded, or -1 (nothing done) if the bank must first
    make room (:meth:`~vilma.sensors.bank.SensorBank.make_room`)."""
    if not counts_fit(tick, n, book, noise, outs):
        return -1
    m = advance(model, integrator, z, mode, cmd, consts_of(consts), dt, n, tick, periods, out_z, out_dx, out_tick)
    measure_all(tick, out_tick[:m], out_z, out_dx, step_ns, book, noise, outs, stamps, par, vec, axes)
    return m
