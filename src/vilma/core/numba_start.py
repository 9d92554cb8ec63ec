"""numba's start-up in a command, without the import of scipy.linalg that no vilma kernel uses."""

from __future__ import annotations

import importlib
import sys

BLAS_PROBE = "scipy.linalg.cython_blas"
"""What :mod:`numba.np.arraymath` imports, on numba's first compile or cache load, to learn if BLAS is there."""


def load_array_support() -> None:
    """Import numba's array implementations now, and let its BLAS probe find no BLAS.

    The probe imports all of scipy.linalg (0.12-0.17 s, a seventh of a ``vilma run``) only to choose how a compiled
    ``np.correlate`` or ``np.convolve`` sums: with BLAS or with numba's own loop. No vilma kernel calls either (nor
    ``np.dot``, ``@`` or ``np.linalg``: the EKF writes its small products as loops). Without the probe they sum with
    the loop in this process; ``np.dot`` and ``np.linalg`` in compiled code still import scipy.linalg when they are
    compiled, as before. Nothing is done when numba's arrays or scipy.linalg are already imported."""
    if "numba.np.arraymath" in sys.modules or "scipy.linalg" in sys.modules:
        return
    sys.modules[BLAS_PROBE] = None  # type: ignore[assignment]  # an import of a None entry raises ImportError
    try:
        importlib.import_module("numba.np.arraymath")
    finally:
        del sys.modules[BLAS_PROBE]
