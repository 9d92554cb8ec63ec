"""numba's start-up without its BLAS probe: compiled code still sums and multiplies as numpy defines."""

import subprocess
import sys

CODE = """
import sys
import numpy as np
from numba import njit
from vilma.core.numba_start import load_array_support

load_array_support()
print('scipy.linalg' in sys.modules, 'numba.np.arraymath' in sys.modules)
print(njit(lambda a, b: np.convolve(a, b))(np.array([1.0, 2.0, 3.0]), np.array([0.0, 1.0, 0.5])).tolist())
print(njit(lambda a, b: a @ b)(np.array([[1.0, 2.0], [3.0, 4.0]]), np.array([5.0, 6.0])).tolist())
"""


def test_probe_skipped_and_blas_still_there_when_compiled():
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[0] == "False True"  # numba's arrays in, scipy.linalg not
    assert out[1] == "[0.0, 1.0, 2.5, 4.0, 1.5]"  # the full convolution, by its definition
    assert out[2] == "[17.0, 39.0]"  # a matrix times a vector: BLAS (scipy.linalg) imported when compiled


def test_nothing_done_when_scipy_linalg_is_in():
    code = ("import sys, scipy.linalg; from vilma.core.numba_start import load_array_support\n"
            "load_array_support(); import numba.np.arraymath as a; print(a._HAVE_BLAS)")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout == "True\n"
