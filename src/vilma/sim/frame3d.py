"""One compiled call a chunk on the 3D plant: MuJoCo's stepping, then every sensor (:mod:`.frame`'s sibling).

Its own module: the 3D plant's kernel loads MuJoCo, which a run on a planar plant never imports.
"""

from __future__ import annotations

from numba import njit

from vilma.plant3d.kernel import advance
from vilma.sensors.bank import counts_fit, measure_all
from vilma.sim.frame import CMD
from vilma.vehicle.state import NZ


@njit(cache=True)
def run_frame_3d(n, tick, t, ptrs, car, traffic, plant, mode, dt, nstep, periods, poses, out_z, out_dx, out_tick,
                 out_3d, step_ns, book, noise, outs, stamps, par):
    """:func:`~vilma.plant3d.kernel.advance` from sim time ``t`` [s] (the plant's arguments from
    :meth:`~vilma.plant3d.plant.MujocoPlant.kernel_args`; ``plant``: the plant vector, command and constants end to
    end as :func:`~vilma.sim.frame.run_frame` takes them), then the bank's :func:`~vilma.sensors.bank.measure_all`;
    returns the rows recorded, or -1 (nothing done) if the bank must first make room."""
    if not counts_fit(tick, n, book, noise, outs):
        return -1
    z, cmd, consts = plant[:NZ], plant[NZ:NZ + CMD], plant[NZ + CMD:]
    m = advance(ptrs, car, traffic, mode, cmd, consts, z, dt, nstep, n, tick, periods, out_z, out_dx, out_tick, out_3d,
                t, poses)
    measure_all(tick, out_tick[:m], out_z, out_dx, out_3d, step_ns, book, noise, outs, stamps, par)
    return m
