import dataclasses
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.planning import FrenetFrame, FrenetState, PlannerParams, RoadBounds, Status, plan
from vilma.planning.candidates import boxes_overlap
from vilma.planning.params import MAX_CANDIDATES, MAX_STEPS
from vilma.trajectory import Arrival, Trajectory

P = PlannerParams()
CAR = P.vehicle
STRAIGHT = FrenetFrame(Trajectory.from_points([(0.0, 0.0), (1000.0, 0.0)]))
NONE = np.zeros((0, P.steps + 1, 5))
LANE = 3.5  # the neighbour lanes' centres are the outer lateral offsets


def _box(x, y, speed, start=0.0, length=4.5, width=1.8):
    """A car heading +x at a constant speed, predicted at the planner's times from ``start`` [s]: (n_t, 5)."""
    t = start + P.times
    return np.column_stack([x + speed * t, np.full_like(t, y), np.zeros_like(t), np.full_like(t, length),
                            np.full_like(t, width)])


def _drive(state, seconds, objects=lambda t: NONE, frame=STRAIGHT, params=P, goal=None):
    """Replan every period from where the last plan put the car (perfect tracking): (start time, plan) pairs."""
    plans = []
    for k in range(round(seconds / params.replan_period)):
        p = plan(state, frame, objects(k * params.replan_period), params, goal)
        plans.append((k * params.replan_period, p))
        state = p.state_at(params.replan_period)
    return plans


def _polygon(x, y, yaw, length, width, offset=0.0):
    c, s = math.cos(yaw), math.sin(yaw)
    cx, cy = x + offset * c, y + offset * s
    corners = [(a * length / 2, b * width / 2) for a, b in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
    return shapely.Polygon([(cx + u * c - v * s, cy + u * s + v * c) for u, v in corners])


def _assert_never_overlaps(plans, objects):
    """Shapely's polygons of the car's real box along each plan and of each object at the same time are apart."""
    for start, p in plans:
        boxes = objects(start)
        for k in range(len(p.t)):
            car = _polygon(p.x[k], p.y[k], p.yaw[k], CAR.length, CAR.width, CAR.body_offset)
            for o in boxes:
                assert not car.intersects(_polygon(*o[k, :3], o[k, 3], o[k, 4])), f"overlap at {start + p.t[k]} s"


def _assert_within_limits(plans, params=P):
    for _, p in plans:
        assert p.mode != "fallback", p.reason
        assert np.abs(p.curvature).max() <= params.max_curvature
        assert (np.abs(p.curvature) * p.speed**2).max() <= params.max_lateral_accel
        assert (p.accel <= CAR.actuators.max_accel).all() and (p.accel >= -CAR.actuators.max_decel).all()
        assert (p.frenet[:, 1] >= -1e-6).all()  # never backwards


def test_on_an_empty_straight_road_it_keeps_the_lane_centre_and_reaches_the_target_speed():
    start = FrenetState(0.0, 5.0, 0.0, 0.0)
    plans = _drive(start, 12.0)
    _assert_within_limits(plans)
    first = plans[0][1]
    assert first.state_at(0.0) == pytest.approx(start) and (first.x[0], first.y[0]) == (0.0, 0.0)
    chosen = np.flatnonzero((first.candidates.x == first.x).all(axis=1) & (first.candidates.y == first.y).all(axis=1))
    assert first.cost in first.candidates.cost[chosen]  # the plan is the candidate of its cost
    assert first.cost == first.candidates.cost[first.candidates.status == Status.FEASIBLE].min()
    last = plans[-1][1]
    assert max(np.abs(p.y).max() for _, p in plans) < 1e-9  # the centre line, y = 0
    assert last.speed == pytest.approx(P.target_speed, abs=1e-3) and last.yaw == pytest.approx(0.0, abs=1e-9)
    assert last.mode == "velocity" and last.reason == ""
    path = last.trajectory
    assert path.speed == pytest.approx(last.speed) and path.length == pytest.approx(np.sum(last.speed[:-1]) * P.dt)
    assert (last.candidates.status == Status.FEASIBLE).sum() > 0


def test_on_a_curve_the_plan_follows_the_reference_at_its_curvature():
    radius = 30.0
    a = np.linspace(0.0, 1.5 * math.pi, 300)
    frame = FrenetFrame(Trajectory.from_points(np.column_stack([radius * np.sin(a), radius * (1 - np.cos(a))])))
    p = plan(FrenetState(10.0, P.target_speed, 0.0, 0.0), frame, NONE, P)
    assert np.hypot(p.x, p.y - radius) == pytest.approx(radius, abs=1e-6)
    assert p.curvature == pytest.approx(1 / radius, rel=1e-3) and p.speed == pytest.approx(P.target_speed)


def test_with_a_stopped_car_in_the_lane_and_the_next_lane_free_it_passes_and_never_overlaps_it():
    def objects(t):
        return _box(40.0, 0.0, 0.0)[None]

    plans = _drive(FrenetState(0.0, 10.0, 0.0, 0.0), 15.0, objects)
    _assert_never_overlaps(plans, objects)
    _assert_within_limits(plans)
    passing = [p for _, p in plans if abs(p.x[0] - 40.0) < 4.5]  # beside the stopped car
    assert passing and all(p.y[0] > 1.0 for p in passing)  # out of its lane to the left (never touching it)
    last = plans[-1][1]
    assert last.x[0] > 100.0 and last.y[0] == pytest.approx(0.0, abs=0.05)  # back in its lane, far past it


def test_with_the_road_only_to_its_right_it_passes_a_stopped_car_there_and_never_leaves_the_road():
    def objects(t):
        return _box(40.0, 0.0, 0.0)[None]

    s = np.array([0.0, 1000.0])
    road = RoadBounds(s, np.full(2, LANE / 2), np.full(2, -1.5 * LANE))  # its lane and one to the right
    plans = []
    state = FrenetState(0.0, 10.0, 0.0, 0.0)
    for k in range(round(15.0 / P.replan_period)):
        p = plan(state, STRAIGHT, objects(0.0), P, road=road)
        plans.append((k * P.replan_period, p))
        state = p.state_at(P.replan_period)
    _assert_never_overlaps(plans, objects)
    _assert_within_limits(plans)
    for _, p in plans:  # the car's box, centre and half extent across the straight road, within its edges
        cy = p.y + CAR.body_offset * np.sin(p.yaw)
        reach = CAR.width / 2 * np.abs(np.cos(p.yaw)) + CAR.length / 2 * np.abs(np.sin(p.yaw))
        assert (cy + reach <= LANE / 2 + 1e-9).all() and (cy - reach >= -1.5 * LANE - 1e-9).all()
    passing = [p for _, p in plans if abs(p.x[0] - 40.0) < 4.5]
    assert passing and all(p.y[0] < -1.0 for p in passing)  # beside it, out of its lane to the right


def test_with_a_stopped_car_in_the_lane_and_the_next_lanes_taken_it_stops_behind_it():
    def objects(t):
        return np.stack([_box(40.0, 0.0, 0.0), _box(36.0, LANE, 0.0), _box(36.0, -LANE, 0.0)])

    plans = _drive(FrenetState(0.0, 10.0, 0.0, 0.0), 15.0, objects)
    _assert_never_overlaps(plans, objects)
    _assert_within_limits(plans)
    last = plans[-1][1]
    gap = 40.0 - 4.5 / 2 - (last.x[0] + CAR.body_offset + CAR.length / 2)
    assert last.speed[0] < 1e-3 and gap == pytest.approx(P.follow_distance, abs=0.1)


def test_behind_a_slower_lead_with_the_other_lanes_blocked_it_follows_at_d0_plus_tau_v():
    v_lead = 8.0
    params = dataclasses.replace(P, target_speed=15.0)

    def objects(t):
        return np.stack([_box(50.0, d, v_lead, t) for d in (0.0, LANE, -LANE)])

    plans = _drive(FrenetState(0.0, 12.0, 0.0, 0.0), 40.0, objects, params=params)
    _assert_never_overlaps(plans, objects)
    _assert_within_limits(plans, params)
    start, last = plans[-1]
    gap = 50.0 + v_lead * start - 4.5 / 2 - (last.x[0] + CAR.body_offset + CAR.length / 2)
    assert last.mode == "follow"
    assert gap == pytest.approx(P.follow_distance + P.time_gap * v_lead, abs=0.1)
    assert last.speed[0] == pytest.approx(v_lead, abs=0.02) and last.y[0] == pytest.approx(0.0, abs=1e-6)


def test_it_stops_at_the_goal_without_passing_it():
    plans = _drive(FrenetState(0.0, 10.0, 0.0, 0.0), 25.0, goal=80.0)
    _assert_within_limits(plans)
    assert max(p.frenet[:, 0].max() for _, p in plans) <= 80.0 + 1e-6
    last = plans[-1][1]
    assert last.mode == "stop" and last.frenet[0, 0] == pytest.approx(80.0, abs=0.05) and last.speed[0] < 1e-3


def test_a_goal_far_ahead_is_stopped_on_braking_no_harder_than_comfortably_and_never_faster():
    # 22 m/s with the goal 184 m ahead: a stop at the mean 22^2 / (2 x 184) = 1.3 m/s^2 is there. Stops that hold
    # the speed to brake later cost less time; chosen each cycle they left no comfortable stop, and the car passed
    # the goal (the road's end on a CommonRoad route) by 5 m
    params = dataclasses.replace(P, target_speed=22.0)
    plans = _drive(FrenetState(0.0, 22.0, 0.0, 0.0), 25.0, params=params, goal=184.0)
    _assert_within_limits(plans)
    driven = round(params.replan_period / params.dt)  # the samples of each plan the car follows
    assert max(p.speed[:driven].max() for _, p in plans) <= 22.0 + 1e-9
    assert min(p.accel[:driven].min() for _, p in plans) >= -CAR.actuators.stop_deceleration
    assert max(p.frenet[:, 0].max() for _, p in plans) <= 184.0 + 1e-6
    last = plans[-1][1]
    assert last.frenet[0, 0] == pytest.approx(184.0, abs=0.05) and last.speed[0] < 1e-3


def test_with_no_feasible_stop_before_the_goal_it_brakes_as_hard_as_the_goal_needs():
    # 6 m/s with 3 m left: the mean 6^2 / (2 x 3) = 6 m/s^2 needs a stop polynomial peaking at 9, beyond the car's 8;
    # the comfortable stop would pass the goal by 3 m, where a road may end
    v, left = 6.0, 3.0
    p = plan(FrenetState(100.0, v, 0.0, 0.0), STRAIGHT, NONE, P, goal=100.0 + left)
    assert (p.candidates.status == Status.INFEASIBLE).all()
    assert p.mode == "fallback" and "goal's stop at 6 m/s^2" in p.reason, p.reason
    assert p.frenet[-1, 0] == pytest.approx(100.0 + left) and p.speed[-1] == pytest.approx(0.0)
    # out of the car's reach: its emergency deceleration, as short as it stops
    p = plan(FrenetState(100.0, 12.0, 0.0, 0.0), STRAIGHT, NONE, P, goal=100.0 + left)
    decel = CAR.actuators.max_decel
    assert p.frenet[-1, 0] == pytest.approx(100.0 + 12.0**2 / (2 * decel)) and f"at {decel:g} m/s^2" in p.reason


@pytest.mark.parametrize(("v", "left"), [(15.0, 0.5), (3.0, 0.1), (20.0, 0.9)])
def test_a_goal_nearer_than_a_step_of_the_stop_is_not_reached_within_one_step(v, left):
    # the steady slow-down to a goal `left` ahead lasts 2 left / v, less than a step (0.1 s): its polynomial went from
    # v to rest between two samples, which the sampled check of the car's deceleration never saw, and it was the plan
    # (15 -> 0 m/s in 0.1 s). No stop is that short: even the car's emergency deceleration needs v^2 / (2 x 8) m
    decel = CAR.actuators.max_decel
    assert v * v / (2.0 * decel) > left and 2.0 * left / v < P.dt
    p = plan(FrenetState(100.0, v, 0.0, 0.0), STRAIGHT, NONE, P, goal=100.0 + left)
    assert p.mode == "fallback" and f"goal's stop at {decel:g} m/s^2" in p.reason, p.reason
    assert (np.diff(p.speed) / P.dt >= -decel - 1e-9).all()
    assert p.frenet[-1, 0] == pytest.approx(100.0 + v * v / (2.0 * decel))


def test_when_every_candidate_collides_it_stops_within_the_braking_distance_it_has():
    # a 30 m truck crossing the road 13 m ahead: no candidate is free (its hardest slow-down, at 90 % of the
    # car's deceleration at its peak, stops in 11.25 m), the comfortable stop too
    v = 10.0
    truck = np.column_stack([np.full_like(P.times, 13.0), -20.0 + 10.0 * P.times, np.full_like(P.times, math.pi / 2),
                             np.full_like(P.times, 30.0), np.full_like(P.times, 2.5)])[None]
    p = plan(FrenetState(0.0, v, 0.0, 0.0), STRAIGHT, truck, P)
    assert (p.candidates.status != Status.FEASIBLE).all()  # the ones within its limits all meet the truck
    decel = CAR.actuators.max_decel
    assert v * v / (2 * CAR.actuators.stop_deceleration) + CAR.body_offset + CAR.length / 2 > 13.0 - 2.5 / 2
    assert p.mode == "fallback" and "emergency" in p.reason and "still collides" not in p.reason
    assert p.cost == math.inf
    assert p.frenet[-1, 0] == pytest.approx(v * v / (2 * decel)) and p.speed[-1] == pytest.approx(0.0)
    assert p.accel[1] == pytest.approx(-decel)
    _assert_never_overlaps([(0.0, p)], lambda t: truck)


def test_when_even_the_emergency_stop_collides_it_swerves_within_the_tyres_grip_and_never_overlaps():
    # a 6 x 3.5 m box across the whole lane 20 m ahead of the car's front at 20 m/s: the emergency stop takes 25 m,
    # and no swerve within 6 m/s^2 clears it in time
    v, gap = 20.0, 20.0
    front = CAR.body_offset + CAR.length / 2
    box = np.column_stack([np.full_like(P.times, front + gap + 3.0), np.zeros_like(P.times), np.zeros_like(P.times),
                           np.full_like(P.times, 6.0), np.full_like(P.times, 3.5)])[None]
    assert v * v / (2 * CAR.actuators.max_decel) > gap
    p = plan(FrenetState(0.0, v, 0.0, 0.0), STRAIGHT, box, P)
    grip = P.evasive_grip * CAR.friction * 9.81
    assert p.mode == "evasive" and "still collides: swerving instead" in p.reason, p.reason
    assert p.lateral[0] in P.evasive_offsets and abs(p.lateral[0]) >= 1.75 + CAR.width / 2  # past the box's side
    assert (np.abs(p.curvature) * p.speed**2).max() <= grip
    _assert_never_overlaps([(0.0, p)], lambda t: box)
    # without evasion it is the emergency stop into the box, said so
    stop = plan(FrenetState(0.0, v, 0.0, 0.0), STRAIGHT, box, dataclasses.replace(P, evasive_grip=0.0))
    assert stop.mode == "fallback" and stop.reason.endswith("which still collides")


def test_the_evasive_end_offsets_are_the_lateral_ones_and_every_half_metre_between_their_extremes():
    params = dataclasses.replace(P, lateral_offsets=(-1.2, 0.0, 1.0))
    assert params.evasive_offsets == pytest.approx((-1.2, -0.7, -0.2, 0.0, 0.3, 0.8, 1.0))
    wide = dataclasses.replace(P, lateral_offsets=(-60.0, 0.0, 60.0), evasive_grip=0.0)  # no evasive tier to sample
    assert wide.candidate_count == 3 * len(P.lateral_durations) * len(P.position_offsets) * (
        len(P.position_durations) + 1)


def test_when_no_candidate_is_feasible_it_stops_at_the_comfortable_deceleration():
    # braking at 2 m/s^2 already, on a car allowed 0.5: every candidate starts beyond the limit
    car = dataclasses.replace(CAR, actuators=dataclasses.replace(CAR.actuators, max_decel=0.5))
    params = dataclasses.replace(P, vehicle=car)
    v = 8.0  # stops within the horizon: 8 / 3 s
    p = plan(FrenetState(0.0, v, -2.0, 0.0), STRAIGHT, NONE, params)
    assert (p.candidates.status == Status.INFEASIBLE).all()
    decel = car.actuators.stop_deceleration
    assert p.mode == "fallback" and "comfortable" in p.reason and "infeasible" in p.reason
    assert p.frenet[-1, 0] == pytest.approx(v * v / (2 * decel)) and p.speed[-1] == pytest.approx(0.0)


def test_a_fallback_from_walking_pace_stops_within_its_braking_distance_and_never_reverses():
    # a stop shorter than one step: 0.15 m/s at 3 m/s^2 stops in 0.05 s, 3.75 mm on
    v = 0.15
    decel = CAR.actuators.stop_deceleration
    p = plan(FrenetState(10.0, v, 0.0, 0.5), STRAIGHT, NONE, P)
    assert p.mode == "fallback"
    assert p.frenet[-1, 0] == pytest.approx(10.0 + v * v / (2 * decel)) and (np.diff(p.frenet[:, 0]) >= 0).all()
    assert p.speed[-1] == pytest.approx(0.0)


@pytest.mark.parametrize("crawl", [1e-60, 1e-310])
def test_creeping_towards_a_far_goal_the_plan_is_finite(crawl):
    # closing at a crawl on a goal 140 m ahead, near enough to plan for at 22 m/s (66 m over the horizon and 161 m
    # to brake): the steady slow-down to it would take 2.8e62 s, or more than a float holds
    p = plan(FrenetState(30.0, crawl, 0.0, 0.0), STRAIGHT, NONE, dataclasses.replace(P, target_speed=22.0),
             goal=170.0)
    assert np.isfinite(p.x).all() and np.isfinite(p.speed).all() and p.mode in ("stop", "fallback")


def test_a_far_goal_at_speed_is_approached_by_the_steady_slow_down():
    # 22 m/s, the goal 183.5 m ahead: near enough to plan for (66 m over the horizon, 161 m to brake), reached
    # only by the slow-down over 2 * 183.5 / 22 = 16.7 s, beyond every sampled duration
    p = plan(FrenetState(0.5, 22.0, 0.0, 0.0), STRAIGHT, NONE, dataclasses.replace(P, target_speed=22.0), goal=184.0)
    assert p.mode == "stop" and 0 < p.speed[-1] < 22.0


def test_a_free_candidate_in_the_goals_window_is_chosen_over_cheaper_ones():
    # 2 m left of the reference at 10 m/s: the cheapest return takes longer than 1.5 s, so the goal 15-25 m ahead,
    # within 0.5 m of the reference and by 1.6 s, is reached only by the swiftest returns
    start = FrenetState(0.0, 10.0, 0.0, 2.0, 0.0, 0.0)
    window = Arrival((15.0, 25.0), (0.0, 1.6), d=np.array([[15.0, 25.0], [-0.5, -0.5], [0.5, 0.5]]))
    cheapest = plan(start, STRAIGHT, NONE, P)
    arrives = plan(start, STRAIGHT, NONE, P, arrivals=(window,))

    def inside(p):
        s, d = p.frenet[:, 0], p.frenet[:, 3]
        return bool(np.any((p.t <= 1.6) & (s >= 15.0) & (s <= 25.0) & (np.abs(d) <= 0.5)))

    assert not inside(cheapest) and inside(arrives)
    assert arrives.cost > cheapest.cost and arrives.mode == "velocity"
    _assert_within_limits([(0.0, arrives)])
    # a window no candidate reaches changes nothing
    missed = dataclasses.replace(window, t=(0.0, 0.5))
    assert plan(start, STRAIGHT, NONE, P, arrivals=(missed,)).cost == cheapest.cost


def test_a_tight_curve_beyond_the_steering_limit_is_infeasible():
    radius = 0.5 / P.max_curvature
    a = np.linspace(0.0, math.pi, 200)
    frame = FrenetFrame(Trajectory.from_points(np.column_stack([radius * np.sin(a), radius * (1 - np.cos(a))])))
    p = plan(FrenetState(0.5, 5.0, 0.0, 0.0), frame, NONE, P)
    assert (p.candidates.status == Status.INFEASIBLE).all() and p.mode == "fallback"


def _road(left, right):
    """Edges at constant offsets ``left`` and ``right`` [m] along :data:`STRAIGHT`."""
    return RoadBounds(np.array([0.0, 1000.0]), np.full(2, left), np.full(2, right))


@settings(deadline=None, max_examples=50)  # the first example loads the compiled code
@given(st.floats(1.5, 8.0), st.floats(1.5, 8.0), st.floats(-1.0, 1.0), st.floats(0.0, 20.0), st.floats(-1.0, 1.0))
def test_the_plan_keeps_the_cars_box_and_margin_within_the_roads_edges(left, right, d, speed, d_dot):
    p = plan(FrenetState(100.0, speed, 0.0, d, d_dot), STRAIGHT, NONE, P, road=_road(left, -right))
    if p.mode == "fallback":
        return  # the fallback stops where it is, edges or not
    grown = (CAR.length + 2 * P.margin, CAR.width + 2 * P.margin)
    for k in range(len(p.t)):
        _, low, _, high = _polygon(p.x[k], p.y[k], p.yaw[k], *grown, CAR.body_offset).bounds
        assert -right - 1e-9 <= low and high <= left + 1e-9, f"off the road at {p.t[k]} s"


def test_on_a_road_narrower_than_the_car_every_candidate_is_infeasible():
    half = 0.5 * CAR.width + P.margin - 0.01
    p = plan(FrenetState(100.0, 10.0, 0.0, 0.0), STRAIGHT, NONE, P, road=_road(half, -half))
    assert (p.candidates.status == Status.INFEASIBLE).all() and p.mode == "fallback"


@settings(deadline=None)  # the first example loads the compiled code
@given(st.floats(-5, 5), st.floats(-5, 5), st.floats(-math.pi, math.pi), st.floats(-math.pi, math.pi),
       st.floats(0.2, 5), st.floats(0.2, 3), st.floats(0.2, 5), st.floats(0.2, 3))
def test_the_separating_axis_check_agrees_with_polygon_intersection(x, y, yaw_a, yaw_b, la, wa, lb, wb):
    a, b = _polygon(0.0, 0.0, yaw_a, la, wa), _polygon(x, y, yaw_b, lb, wb)
    if a.distance(b) < 1e-9 and a.intersection(b).area < 1e-9:
        return  # touching within rounding: either answer is right
    assert boxes_overlap(0.0, 0.0, yaw_a, la / 2, wa / 2, x, y, yaw_b, lb / 2, wb / 2) == a.intersects(b)


@pytest.mark.parametrize(("change", "message"), [
    ({"horizon": 0.0}, "planner horizon must be a finite number > 0"),
    ({"horizon": -1.0}, "planner horizon must be a finite number > 0"),
    ({"lateral_offsets": ()}, "planner lateral_offsets is empty"),
    ({"speed_durations": ()}, "planner speed_durations is empty"),
    ({"horizon": 2.95}, "not a whole number of dt"),
    ({"horizon": 100.0, "dt": 0.1}, f"over the limit of {MAX_STEPS}"),
    ({"lateral_offsets": tuple(range(100))}, f"over the limit of {MAX_CANDIDATES}"),
    ({"replan_period": 4.0}, "longer than the horizon"),
    ({"margin": -0.1}, "planner margin must be >= 0"),
    ({"evasive_grip": 1.5}, "planner evasive_grip must be within 0 .. 1"),
    ({"lateral_offsets": (-60.0, 0.0, 60.0)}, "evasive tier's end offsets are every 0.5 m"),
    ({"position_offsets": (0.0, 1.0)}, "position_offsets must be <= 0 m"),
])
def test_bad_parameters_are_a_one_line_error(change, message):
    with pytest.raises(ValueError, match=message) as e:
        dataclasses.replace(P, **change)
    assert "\n" not in str(e.value)


def test_malformed_objects_or_state_are_a_one_line_error():
    with pytest.raises(ValueError, match=r"\(n_obj, 31, 5\)") as e:
        plan(FrenetState(0.0, 1.0, 0.0, 0.0), STRAIGHT, np.zeros((2, 30, 5)), P)
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match="must be finite"):
        plan(FrenetState(math.nan, 1.0, 0.0, 0.0), STRAIGHT, NONE, P)
