"""One compiled call a chunk on a planar plant: the physics, then every sensor (the 3D plant's: :mod:`.frame3d`).

A 20 ms frame is two physics steps and a reading or two of each sensor: the work takes a few microseconds, so
what the call costs is its arguments. Its arrays cross as one table of addresses (:mod:`vilma.core.arrays`: numba
unboxes each array argument for some 40 ns); the plant's 30 constants are in one array with the plant vector and the
command (as a tuple they cost more than the whole frame: numba types a named tuple field by field on every call);
and :func:`direct` skips typing the arguments at all.
"""

from __future__ import annotations

import numpy as np
from numba import njit, typeof

from vilma.core.arrays import matrix, vector
from vilma.sensors.bank import counts_fit, measure_all
from vilma.sensors.base import NO_3D
from vilma.vehicle.actuators import consts_of
from vilma.vehicle.integrate import advance
from vilma.vehicle.state import NZ

CMD = 4
"""Values of the command in force: ``steer, drive, brake, velocity limit``; in ``plant`` after the plant vector."""


ARRAYS = ((np.float64, 1), (np.int64, 1), (np.float64, 2), (np.float64, 2), (np.int64, 1), (np.int64, 2),
          (np.float64, 2), (np.float64, 2), (np.int64, 2), (np.float64, 2))
"""The layout of :func:`run_frame`'s table of arrays: ``plant`` (the plant vector, the command (:data:`CMD`) and the
constants, :func:`~vilma.vehicle.actuators.consts_of`, end to end), ``periods``, the records ``out_z, out_dx,
out_tick``, and the sensor bank's ``book, noise, outs, stamps, par``."""


@njit(cache=True)
def frame_arrays(arrays, first):
    """The arrays of :data:`ARRAYS` from row ``first`` of the table ``arrays``: ``plant, periods, out_z, out_dx,
    out_tick, book, noise, outs, stamps, par``."""
    f8, i8 = np.float64, np.int64
    return (vector(arrays, first, f8), vector(arrays, first + 1, i8), matrix(arrays, first + 2, f8),
            matrix(arrays, first + 3, f8), vector(arrays, first + 4, i8), matrix(arrays, first + 5, i8),
            matrix(arrays, first + 6, f8), matrix(arrays, first + 7, f8), matrix(arrays, first + 8, i8),
            matrix(arrays, first + 9, f8))


@njit(cache=True)
def run_frame(n, tick, model, integrator, mode, dt, step_ns, arrays):
    """:func:`~vilma.vehicle.integrate.advance` of the plant, then the bank's
    :func:`~vilma.sensors.bank.measure_all`, on the arrays of the table ``arrays`` (:data:`ARRAYS`); returns the rows
    recorded, or -1 (nothing done) if the bank must first make room
    (:meth:`~vilma.sensors.bank.SensorBank.make_room`)."""
    plant, periods, out_z, out_dx, out_tick, book, noise, outs, stamps, par = frame_arrays(arrays, 0)
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
