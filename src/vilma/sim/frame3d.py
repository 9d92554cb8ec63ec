"""One compiled call a chunk on the 3D plant: MuJoCo's stepping, then every sensor (:mod:`.frame`'s sibling).

Its own module: the 3D plant's kernel loads MuJoCo, which a run on a planar plant never imports.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from vilma.core.arrays import matrix, vector
from vilma.plant3d.kernel import advance
from vilma.sensors.bank import counts_fit, measure_all
from vilma.sim.frame import ARRAYS, CMD, frame_arrays
from vilma.vehicle.state import NZ

CAR = ((np.float64, 1),) * 7 + ((np.int32, 1), (np.float64, 1), (np.int64, 1), (np.float64, 1), (np.float64, 1),
       (np.uint64, 1))
"""The layout of a car's arrays (:mod:`vilma.plant3d.kernel`: ``qpos`` .. ``io``, the profiler's timer)."""
_C = len(CAR)
ARRAYS_3D = CAR + ARRAYS + ((np.float64, 2),)
"""The layout of :func:`run_frame_3d`'s table of arrays: the car's (:data:`CAR`), :data:`~.frame.ARRAYS`, then the 3D
plant's records ``out_3d``."""
_OUT_3D = _C + len(ARRAYS)


@njit(cache=True)
def _car(a):
    """The car tuple of the first rows of the table ``a`` (:data:`CAR`)."""
    f8 = np.float64
    return (vector(a, 0, f8), vector(a, 1, f8), vector(a, 2, f8), vector(a, 3, f8), vector(a, 4, f8),
            vector(a, 5, f8), vector(a, 6, f8), vector(a, 7, np.int32), vector(a, 8, f8), vector(a, 9, np.int64),
            vector(a, 10, f8), vector(a, 11, f8), vector(a, 12, np.uint64))


@njit(cache=True)
def run_frame_3d(n, tick, t, ptrs, traffic, mode, dt, nstep, poses, step_ns, arrays):
    """:func:`~vilma.plant3d.kernel.advance` from sim time ``t`` [s] (the plant's ``ptrs``, ``traffic`` and
    ``nstep`` from :meth:`~vilma.plant3d.plant.MujocoPlant.kernel_args`), then the bank's
    :func:`~vilma.sensors.bank.measure_all`, on the arrays of the table ``arrays`` (:data:`ARRAYS_3D`); returns the
    rows recorded, or -1 (nothing done) if the bank must first make room."""
    plant, periods, out_z, out_dx, out_tick, book, noise, outs, stamps, par = frame_arrays(arrays, _C)
    if not counts_fit(tick, n, book, noise, outs):
        return -1
    out_3d = matrix(arrays, _OUT_3D, np.float64)
    z, cmd, consts = plant[:NZ], plant[NZ:NZ + CMD], plant[NZ + CMD:]
    m = advance(ptrs, _car(arrays), traffic, mode, cmd, consts, z, dt, nstep, n, tick, periods, out_z, out_dx,
                out_tick, out_3d, t, poses)
    measure_all(tick, out_tick[:m], out_z, out_dx, out_3d, step_ns, book, noise, outs, stamps, par)
    return m
