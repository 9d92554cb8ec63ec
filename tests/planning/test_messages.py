"""A planning cycle and its tracks as bus messages."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from vilma.bus.codec import decode, encode
from vilma.core.messages import LocalPlan, TrackList
from vilma.perception import Track, predict
from vilma.planning import FrenetFrame, FrenetState, PlannerParams, Status, local_plan, plan, track_list
from vilma.planning.messages import drawn_candidates
from vilma.trajectory import Trajectory

P = PlannerParams()
STRAIGHT = FrenetFrame(Trajectory.from_points([(0.0, 0.0), (1000.0, 0.0)]))
LEAD = Track(7, 30.0, 0.0, 0.0, 5.0, 0.0, 4.5, 1.8, np.diag([0.1, 0.2, 0.3, 0.4]), 2.5)


def test_a_cycle_is_a_message_with_its_trajectory_candidates_and_predictions():
    boxes = predict([LEAD], P.times)
    p = plan(FrenetState(0.0, 10.0, 0.0, 0.0), STRAIGHT, boxes, P)
    msg = decode(encode(local_plan(123, p, [LEAD], boxes, drawn=20)), LocalPlan)
    assert (msg.stamp_ns, msg.mode, msg.dt) == (123, p.mode, P.dt)
    assert np.array_equal(msg.x, p.x) and np.array_equal(msg.y, p.y) and np.array_equal(msg.speed, p.speed)
    assert 0 < len(msg.candidates) <= 20
    for c in msg.candidates:  # each drawn candidate is one of the cycle's, with its status
        i = np.flatnonzero((p.candidates.x == c.x).all(axis=1) & (p.candidates.y == c.y).all(axis=1))
        assert len(i) >= 1 and p.candidates.status[i[0]] == c.status
    (pred,) = msg.predictions  # the lead at constant velocity: 5 m/s along x
    assert pred.id == 7 and np.allclose(pred.x, 30.0 + 5.0 * P.times) and np.allclose(pred.y, 0.0)


def test_tracks_are_a_message_with_their_covariance_and_age():
    msg = decode(encode(track_list(5, "laser", [LEAD])), TrackList)
    (o,) = msg.objects
    assert msg.source == "laser" and (o.id, o.x, o.vx, o.length, o.age) == (7, 30.0, 5.0, 4.5, 2.5)
    assert np.array_equal(np.reshape(o.covariance, (4, 4)), LEAD.covariance)


@given(st.lists(st.tuples(st.sampled_from(list(Status)), st.floats(0, 100)), max_size=200), st.integers(0, 80))
def test_drawn_candidates_are_the_cheapest_free_and_a_sample_of_the_rejected(cands, drawn):
    status = np.array([c[0] for c in cands], np.int8)
    cost = np.array([c[1] for c in cands])
    pick = drawn_candidates(status, cost, drawn)
    assert len(pick) == len(set(pick)) <= drawn
    free, rejected = pick[status[pick] == Status.FEASIBLE], pick[status[pick] != Status.FEASIBLE]
    n_free, n_rejected = int((status == Status.FEASIBLE).sum()), int((status != Status.FEASIBLE).sum())
    assert len(free) >= min(n_free, drawn // 2) and len(rejected) >= min(n_rejected, drawn // 2)
    assert len(pick) == min(drawn, len(cands))
    others = np.setdiff1d(np.flatnonzero(status == Status.FEASIBLE), free)
    assert len(others) == 0 or len(free) == 0 or cost[free].max() <= cost[others].min()  # the cheapest free
