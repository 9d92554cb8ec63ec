"""Many arrays handed to compiled code as one: a table of their addresses and shapes (:func:`table`), made views
again inside (:func:`vector`, :func:`matrix`).

numba unboxes each array argument of a call for some 40 ns: a simulator frame passes 10 arrays (planar plant, a
tenth of its 20 ms frame, ``benchmarks/sensors_speed.py``) to 23 (3D plant, 0.7 us, ``plant3d.py``); one table costs
one. The views are only as sound as their table: the caller keeps the arrays alive as long as it passes their
table (:class:`~vilma.sim.Simulator` holds both together), and a view's dtype and dimensions are those its row was
made with (:func:`table` checks each array against the layout the compiled code reads it with).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic

Layout = Sequence[tuple[type, int]]
"""What compiled code reads each row as: ``(dtype, dimensions)`` (1 or 2), in order."""


def table(arrays: Sequence[np.ndarray], layout: Layout) -> np.ndarray:
    """(n, 3) int64: each array's address and shape (a vector's second dimension 0), checked against ``layout``.

    Raises:
        TypeError: an array is not C-contiguous or not of its row's dtype and dimensions.
    """
    rows = np.zeros((len(layout), 3), dtype=np.int64)
    for k, (a, (dtype, ndim)) in enumerate(zip(arrays, layout, strict=True)):
        if a.dtype != dtype or a.ndim != ndim or not a.flags.c_contiguous:
            raise TypeError(f"row {k}: a {a.ndim}-d {a.dtype} array (C-contiguous: {a.flags.c_contiguous}) where "
                            f"compiled code reads a C-contiguous {ndim}-d {np.dtype(dtype)} one")
        rows[k, 0] = a.ctypes.data
        rows[k, 1:1 + ndim] = a.shape
    return rows


@intrinsic
def _pointer(typingctx, address):
    """The integer ``address`` as a pointer (LLVM's ``inttoptr``)."""

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], cgutils.voidptr_t)

    return types.voidptr(types.int64), codegen


@njit(cache=True)
def vector(rows, k, dtype):
    """The 1-d array of row ``k`` of a :func:`table`, of ``dtype``."""
    return carray(_pointer(rows[k, 0]), rows[k, 1], dtype)


@njit(cache=True)
def matrix(rows, k, dtype):
    """The 2-d array of row ``k`` of a :func:`table`, of ``dtype``."""
    return carray(_pointer(rows[k, 0]), (rows[k, 1], rows[k, 2]), dtype)
