import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.planning import FrenetFrame, PlannerParams
from vilma.planning.candidates import check_candidates
from vilma.planning.planner import _car
from vilma.planning.polynomials import evaluate, quartic, quintic
from vilma.trajectory import Trajectory

P = PlannerParams()
REFERENCE = FrenetFrame(Trajectory.from_points([(0.0, 0.0), (40.0, 0.0), (80.0, 20.0)]))  # a bend to the left
FRAME = REFERENCE.arrays
T = np.repeat([1.0, 2.5], 3)
LAT = evaluate(quintic(0.0, 0.0, 0.0, np.tile([-3.5, 0.0, 3.5], 2), 0.0, 0.0, T), T, P.times)[:3]  # 1 s: too swift
TS = np.array([1.0, 2.0, 2.0])
LON = evaluate(quartic(0.0, 10.0, 0.0, np.array([0.0, 10.0, 14.0]), 0.0, TS), TS, P.times)[:3]  # to rest: too hard
CI, CJ = (a.astype(np.intp) for a in np.divmod(np.arange(LAT.shape[1] * LON.shape[1]), LON.shape[1]))
EDGES = np.stack([np.full(LON[0].shape, 5.0), np.full(LON[0].shape, -5.0)])  # the outer lanes' cars just fit


def _objects(s, d):
    """A box at rest at arc length ``s`` and offset ``d`` [m] along the reference, 4.5 x 1.8 m: (1, n_t, 5)."""
    (x,), (y,) = REFERENCE.to_cartesian([s], [d])
    return np.tile([x, y, REFERENCE.pose(s)[2], 4.5, 1.8], (1, len(P.times), 1))


def _checked(order, objects, whole, check_all=False):
    """:func:`check_candidates` in ``order``: the first free candidate, the motions (6, n, n_t), the statuses (n,)."""
    out, status = np.empty((6, len(CI), len(P.times))), np.full(len(CI), -1, np.int8)
    first = check_candidates(FRAME, LAT, LON, EDGES, CI, CJ, np.array(order, np.intp), objects, _car(P), P.margin,
                             whole, check_all, out, status)
    return first, out, status


@settings(deadline=None, max_examples=60)  # the first example loads the compiled code
@given(st.permutations(range(len(CI))), st.floats(5.0, 45.0), st.sampled_from([-3.5, 0.0, 3.5, 20.0]))
def test_the_first_free_candidate_in_an_order_is_the_first_there_that_the_check_of_all_finds_free(order, s, d):
    """Checked one by one in an order, each up to its first failing step, the first free one is the one the
    check of every candidate (infeasible by its lateral time or braking, or colliding with the box) finds first,
    with the same motion; the candidates checked before it have the statuses the whole check gives them."""
    objects = _objects(s, d)
    _, every, status = _checked(range(len(CI)), objects, whole=True)
    chosen, out, seen = _checked(order, objects, whole=False)
    free = [c for c in order if status[c] == 0]
    assert chosen == (free[0] if free else -1)
    checked = order[:order.index(chosen) + 1] if free else order
    np.testing.assert_array_equal(seen[checked], status[checked])
    if free:
        np.testing.assert_array_equal(out[:, chosen], every[:, chosen])


def test_a_car_box_overlapping_an_object_collides_and_only_the_feasible_are_checked_unless_all_are_asked_for():
    """On the reference (lateral motion 4: to no offset in 2.5 s), kept at speed (longitudinal 1), the car's box
    meets a box at rest 20 m ahead on the reference; beside it, in the next lane (3.5 m), it does not. Braking to
    rest in 1 s (longitudinal 0) is infeasible, colliding or not."""
    _, _, status = _checked(range(len(CI)), _objects(20.0, 0.0), whole=True)
    _, _, beside = _checked(range(len(CI)), _objects(20.0, 3.5), whole=True)
    _, _, every = _checked(range(len(CI)), _objects(0.0, 0.0), whole=True, check_all=True)
    assert status[4 * 3 + 1] == 2 and beside[4 * 3 + 1] == 0
    assert status[4 * 3 + 0] == 1 and every[4 * 3 + 0] == 2  # (the box at the start overlaps the car there)
