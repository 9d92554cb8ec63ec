"""Noise models: white Gaussian noise and a slowly drifting (first-order Gauss-Markov) bias."""

from __future__ import annotations

import math

import numpy as np
from numba import njit


def standard_normals(rng: np.random.Generator, n: int, dims: int) -> np.ndarray:
    """All the standard normal draws of ``n`` samples, (n, dims), in one call.

    A sensor takes all its noise for a batch from one call, row by row, so
    sample ``i`` gets the same numbers however the run is split into batches.
    """
    return rng.standard_normal((n, dims))


class GaussMarkovBias:
    """Bias that drifts as ``b[k] = phi b[k-1] + w[k]`` with ``phi = exp(-T/tau)``.

    Its stationary standard deviation is ``sigma`` [unit of the signal] and its
    correlation time ``tau`` [s]; ``sigma = 0`` gives no bias. The state ``b``
    is advanced in compiled sensor code by :func:`gauss_markov_step`.
    """

    def __init__(self, sigma: float, tau: float, period: float, dims: int) -> None:
        self.sigma, self.dims = sigma, dims
        self.phi = math.exp(-period / tau) if tau > 0 else 0.0
        self.step_sigma = sigma * math.sqrt(1.0 - self.phi**2)
        self.b = np.zeros(dims)

    def reset(self, rng: np.random.Generator) -> None:
        """Draw the starting bias from the stationary distribution."""
        self.b = rng.standard_normal(self.dims) * self.sigma


@njit(cache=True, error_model="numpy")
def gauss_markov_step(b, phi, step_sigma, normals):
    """Advance bias state ``b`` (in place) by one sample driven by ``normals``; returns ``b``."""
    for d in range(b.shape[0]):
        b[d] = phi * b[d] + step_sigma * normals[d]
    return b
