"""The least a process that runs numba-compiled code pays before its first result: the interpreter, numpy, numba,
and numba's first load of a cached function (its target and array support), as a ``vilma`` command starts them
(the garbage collector held off, :mod:`vilma.app.collector`; :func:`vilma.core.numba_start.load_array_support`),
ending as such a command ends (:func:`vilma.app.cli.entry`:
the exit handlers, then no teardown). Nothing of vilma's own runs.

    python benchmarks/anchors/numba_floor.py
"""

import atexit
import os

from vilma.app import collector

collector.starting()

from numba import njit  # noqa: E402 (after the collector is held off, as in a command)

from vilma.core.numba_start import load_array_support  # noqa: E402


@njit(cache=True)
def _one(x: float) -> float:
    return x + 1.0


if __name__ == "__main__":
    load_array_support()
    print(_one(1.0), flush=True)
    atexit._run_exitfuncs()
    os._exit(0)
