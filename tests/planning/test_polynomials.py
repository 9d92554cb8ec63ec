import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.polynomial import polynomial as npoly
from scipy.integrate import quad

from vilma.planning.polynomials import evaluate, jerk_cost, quartic, quintic, to_rest

value = st.floats(-50.0, 50.0)
duration = st.floats(0.5, 10.0)


def _at(coeffs, T, t):
    return evaluate(coeffs, T, np.asarray([t], dtype=float))[:, 0]


@settings(deadline=None)  # the first example loads the compiled code
@given(value, value, value, value, value, value, duration)
def test_a_quintic_meets_its_six_boundary_conditions(x0, v0, a0, x1, v1, a1, T):
    c = quintic(x0, v0, a0, x1, v1, a1, T)
    assert _at(c, T, 0.0)[:3] == pytest.approx([x0, v0, a0], abs=1e-9)
    assert _at(c, T, T)[:3] == pytest.approx([x1, v1, a1], rel=1e-9, abs=1e-7)


@settings(deadline=None)  # the first example loads the compiled code
@given(value, value, value, value, value, duration)
def test_a_quartic_meets_its_five_boundary_conditions(x0, v0, a0, v1, a1, T):
    c = quartic(x0, v0, a0, v1, a1, T)
    assert c[5] == 0.0
    assert _at(c, T, 0.0)[:3] == pytest.approx([x0, v0, a0], abs=1e-9)
    assert _at(c, T, T)[1:3] == pytest.approx([v1, a1], rel=1e-9, abs=1e-7)


def test_rest_to_rest_quintic_is_the_minimum_jerk_motion():
    # Flash and Hogan 1985: from rest to rest over D in T, x = D (10 u^3 - 15 u^4 + 6 u^5), u = t / T
    D, T = 7.0, 2.0
    assert quintic(0.0, 0.0, 0.0, D, 0.0, 0.0, T) == pytest.approx([0, 0, 0, 10 * D / T**3, -15 * D / T**4,
                                                                    6 * D / T**5])


def test_evaluation_is_vectorised_and_goes_on_at_the_end_rate_past_the_duration():
    c = quintic([0.0, 1.0], 0.0, 0.0, [3.5, -2.0], [0.0, 4.0], 0.0, [2.0, 3.0])
    t = np.array([0.0, 2.0, 3.0, 5.0])
    x, v, a, j = evaluate(c, [2.0, 3.0], t)
    assert x.shape == (2, 4)
    assert x[0] == pytest.approx([0.0, 3.5, 3.5, 3.5])  # the lane offset is held
    assert x[1, 3] == pytest.approx(-2.0 + 4.0 * 2.0) and v[1, 3] == pytest.approx(4.0)  # the end speed is kept
    assert a[:, 3] == pytest.approx([0.0, 0.0]) and j[:, 3] == pytest.approx([0.0, 0.0])


@settings(deadline=None)  # the first example loads the compiled code
@given(st.lists(st.tuples(*[value] * 6, duration), min_size=1, max_size=6), st.lists(st.floats(0.0, 12.0), max_size=8))
def test_evaluation_of_a_batch_is_each_polynomial_and_its_derivatives(polys, t):
    c, T, t = np.array([p[:6] for p in polys]), np.array([p[6] for p in polys]), np.array(t)
    got = evaluate(c.reshape(-1, 1, 6), T.reshape(-1, 1), t)
    assert got.shape == (4, len(polys), 1, len(t))
    for i, (coeffs, duration) in enumerate(zip(c, T, strict=True)):
        tau = np.minimum(t, duration)
        want = [npoly.polyval(tau, npoly.polyder(coeffs, n)) if n else npoly.polyval(tau, coeffs) for n in range(4)]
        want[0] = want[0] + want[1] * (t - tau)  # on at the end rate past the duration
        want[2], want[3] = np.where(t > duration, 0.0, want[2]), np.where(t > duration, 0.0, want[3])
        assert got[:, i, 0] == pytest.approx(np.array(want), rel=1e-9, abs=1e-6)


@given(value, value, value, value, value, value, duration)
def test_jerk_cost_is_the_integral_of_the_squared_jerk(x0, v0, a0, x1, v1, a1, T):
    c = quintic(x0, v0, a0, x1, v1, a1, T)
    numeric, _ = quad(lambda t: _at(c, T, t)[3] ** 2, 0.0, T)
    assert jerk_cost(c, T) == pytest.approx(numeric, rel=1e-7, abs=1e-9)


@settings(deadline=None)  # the first example loads the compiled code
@given(value, value, value, st.lists(st.tuples(value, value, st.floats(0.05, 300.0)), min_size=1, max_size=40))
def test_polynomials_to_rest_in_one_call_are_the_quintics_and_quartics_and_their_jerk_costs_bit_for_bit(
        x0, v0, a0, ends):
    """The planner's longitudinal motions in one compiled call change no planning outcome: the same bits as the
    quintic's and quartic's closed forms and the jerk integral (durations up to the slow-down's 100 horizons)."""
    x1, v1, T = (np.array(c) for c in zip(*ends, strict=True))
    for x, want in ((x1, quintic(x0, v0, a0, x1, v1, 0.0, T)), (None, quartic(x0, v0, a0, v1, 0.0, T))):
        coeffs, cost = to_rest(x0, v0, a0, x, v1, T)
        np.testing.assert_array_equal(coeffs, want)
        np.testing.assert_array_equal(cost, jerk_cost(want, T))


def test_a_duration_that_is_not_positive_is_an_error():
    with pytest.raises(ValueError, match="duration must be > 0 s"):
        quintic(0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="duration must be > 0 s"):
        to_rest(0.0, 0.0, 0.0, None, np.ones(2), np.array([1.0, 0.0]))
    with pytest.raises(ValueError, match="duration must be > 0 s"):
        quartic(0.0, 0.0, 0.0, 1.0, 0.0, [1.0, -1.0])
