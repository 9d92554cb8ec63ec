"""One compiled call a chunk on a planar plant: the physics, then every sensor (the 3D plant's: :mod:`.frame3d`).

A 20 ms frame is two physics steps and a reading or two of each sensor: the work takes a few microseconds, so
what the call costs is its arguments. They cross as flat arrays, few of them (numba unboxes each array for some
40 ns): the plant's 30 constants as a tuple cost more than the whole frame (numba types a named tuple field by field
on every call), in one array with the plant vector and the command almost nothing; and :func:`direct` skips typing
them at all.
"""

from __future__ import annotations

from numba import njit, typeof

from vilma.sensors.bank import counts_fit, measure_all
from vilma.sensors.base import NO_3D
from vilma.vehicle.actuators import consts_of
from vilma.vehicle.integrate import advance
from vilma.vehicle.state import NZ

CMD = 4
"""Values of the command in force: ``steer, drive, brake, velocity limit``; in ``plant`` after the plant vector."""


@njit(cache=True)
def run_frame(n, tick, model, integrator, plant, mode, dt, periods, out_z, out_dx, out_tick, step_ns, book, noise,
              outs, stamps, par):
    """:func:`~vilma.vehicle.integrate.advance` of the plant vector, command (:data:`CMD`) and constants (as an
    array, :func:`~vilma.vehicle.actuators.consts_of`) end to end in ``plant``, then the bank's
    :func:`~vilma.sensors.bank.measure_all`; returns the rows recorded, or -1 (nothing done) if the bank must first
    make room (:meth:`~vilma.sensors.bank.SensorBank.make_room`)."""
    if not counts_fit(tick, n, book, noise, outs):
        return -1
    z, cmd, consts = plant[:NZ], plant[NZ:NZ + CMD], plant[NZ + CMD:]
    m = advance(model, integrator, z, mode, cmd, consts_of(consts), dt, n, tick, periods, out_z, out_dx, out_tick)
    measure_all(tick, out_tick[:m], out_z, out_dx, NO_3D, step_ns, book, noise, outs, stamps, par)
    return m


def direct(dispatcher, *args):
    """``dispatcher``'s compiled code for the types of ``args`` (compiled or loaded from numba's cache now), to call
    directly: numba typing a frame's arguments at each call cost 0.4 us of its 7. Later calls must pass the same
    types."""
    return dispatcher.compile(tuple(typeof(a) for a in args))
