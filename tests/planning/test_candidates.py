import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.planning import FrenetFrame, PlannerParams
from vilma.planning.candidates import combine, first_free
from vilma.planning.planner import _car
from vilma.planning.polynomials import evaluate, quartic, quintic
from vilma.trajectory import Trajectory

P = PlannerParams()
FRAME = FrenetFrame(Trajectory.from_points([(0.0, 0.0), (40.0, 0.0), (80.0, 20.0)])).arrays
T = np.repeat([1.0, 2.5], 3)
LAT = evaluate(quintic(0.0, 0.0, 0.0, np.tile([-3.5, 0.0, 3.5], 2), 0.0, 0.0, T), T, P.times)[:3]  # 1 s: too swift
TS = np.array([1.0, 2.0, 2.0])
LON = evaluate(quartic(0.0, 10.0, 0.0, np.array([0.0, 10.0, 14.0]), 0.0, TS), TS, P.times)[:3]  # to rest: too hard
CI, CJ = (a.astype(np.intp) for a in np.divmod(np.arange(LAT.shape[1] * LON.shape[1]), LON.shape[1]))
EDGES = np.stack([np.full(LON[0].shape, 5.0), np.full(LON[0].shape, -5.0)])  # the outer lanes' cars just fit


def _objects(x, y):
    """A box at rest at (x, y) [m], 4.5 x 1.8 m, at every step: (1, n_t, 5)."""
    return np.tile([x, y, 0.0, 4.5, 1.8], (1, len(P.times), 1))


@settings(deadline=None, max_examples=60)  # the first example loads the compiled code
@given(st.permutations(range(len(CI))), st.floats(5.0, 45.0), st.sampled_from([-3.5, 0.0, 3.5, 20.0]))
def test_the_first_free_candidate_in_an_order_is_the_first_there_that_the_check_of_all_finds_free(order, x, y):
    """Checked one by one in an order, each up to its first failing step, the first free one is the one the
    check of every candidate (infeasible by its lateral time or braking, or colliding with the box) finds first,
    with the same motion."""
    objects, car = _objects(x, y), _car(P)
    every, status = np.empty((6, len(CI), len(P.times))), np.empty(len(CI), np.int8)
    combine(FRAME, LAT, LON, EDGES, CI, CJ, objects, car, P.margin, False, every, status)
    out = np.empty((6, len(P.times)))
    chosen = first_free(FRAME, LAT, LON, EDGES, CI, CJ, np.array(order, np.intp), objects, car, P.margin, out)
    free = [c for c in order if status[c] == 0]
    assert chosen == (free[0] if free else -1)
    if free:
        np.testing.assert_array_equal(out, every[:, chosen])
