import math

import numpy as np
import pytest

from vilma.sensors.noise import GaussMarkovBias, gauss_markov_step, standard_normals


def _series(b: GaussMarkovBias, normals: np.ndarray) -> np.ndarray:
    return np.array([gauss_markov_step(b.b, b.phi, b.step_sigma, row).copy() for row in normals])


def test_gauss_markov_has_its_stationary_sigma_and_correlation_time():
    rng = np.random.default_rng(3)
    sigma, tau, period = 2.0, 5.0, 0.1
    b = GaussMarkovBias(sigma, tau, period, 1)
    b.reset(rng)
    x = _series(b, standard_normals(rng, 100_000, 1))[:, 0]
    assert x.std() == pytest.approx(sigma, rel=0.05)
    lag = round(tau / period)
    corr = np.corrcoef(x[:-lag], x[lag:])[0, 1]
    assert corr == pytest.approx(math.exp(-1), abs=0.05)


def test_zero_sigma_is_no_bias():
    b = GaussMarkovBias(0.0, 10.0, 0.1, 3)
    b.reset(np.random.default_rng(1))
    assert not _series(b, np.ones((5, 3))).any()


def test_batches_continue_one_stream():
    rng1, rng2 = np.random.default_rng(9), np.random.default_rng(9)
    whole = standard_normals(rng1, 10, 3)
    parts = np.vstack([standard_normals(rng2, 4, 3), standard_normals(rng2, 6, 3)])
    assert np.array_equal(whole, parts)
