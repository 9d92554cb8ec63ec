"""The scorecard on drives whose figures follow from kinematics (not from a run of vilma)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import shapely
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.scenario.drive_log import COLUMNS, DriveLog
from vilma.scenario.metrics import (
    check_expectations,
    completion,
    convex_gap,
    coverage,
    scorecard,
    step_response,
    timing,
    unmeasured,
)
from vilma.scenario.spec import SCORECARD_KEYS, Bound, MetricsSpec, Scenario, TaskSpec
from vilma.trajectory import Trajectory

DT = 0.02


def _log(t, **cols) -> DriveLog:
    log = DriveLog(capacity=8)  # small: the buffer grows
    rows = np.zeros((len(t), len(COLUMNS)))
    rows[:, 0] = t
    for name, values in cols.items():
        rows[:, COLUMNS.index(name)] = values
    for r in rows:
        log.add(r)
    return log


def test_first_order_speed_step():
    """v = V (1 - exp(-t / tau)): t90 = tau ln 10, no overshoot, 2 % settling at tau ln 50."""
    tau, target = 3.0, 10.0
    t = np.arange(0, 40, DT)
    v = target * (1 - np.exp(-t / tau))
    s = step_response(t, v, target, 0.02, 5.0)
    assert s["speed_rise_time_90_s"] == pytest.approx(tau * math.log(10), abs=1e-3)
    assert s["speed_overshoot_pct"] == 0.0
    assert s["speed_settling_time_2pct_s"] == pytest.approx(tau * math.log(50), abs=DT)
    assert s["speed_steady_state_error_mps"] == pytest.approx(0.0, abs=1e-4)


def test_a_step_down_from_a_moving_start_is_measured_on_the_step():
    """v = 5 + 5 exp(-t / tau) from 10 m/s to a 5 m/s target: 90 % of the 5 m/s step at tau ln 10, no overshoot
    (it never goes below 5 m/s), inside 2 % of the target (0.1 m/s) from tau ln 50; not a rise at t = 0 with
    the 100 % overshoot of v.max() / target."""
    tau = 3.0
    t = np.arange(0, 40, DT)
    s = step_response(t, 5.0 + 5.0 * np.exp(-t / tau), 5.0, 0.02, 5.0, start=10.0)
    assert s["speed_rise_time_90_s"] == pytest.approx(tau * math.log(10), abs=1e-3)
    assert s["speed_overshoot_pct"] == 0.0
    assert s["speed_settling_time_2pct_s"] == pytest.approx(tau * math.log(50), abs=DT)


def test_a_step_up_from_a_moving_start_overshoots_in_percent_of_the_step():
    """From 5 to 10 m/s peaking at 10.5 m/s: 0.5 m/s past the target is 10 % of the 5 m/s step."""
    t = np.arange(0, 20, DT)
    v = np.minimum(5.0 + t, 10.5 - 0.05 * np.maximum(t - 5.5, 0.0))
    s = step_response(t, v, 10.0, 0.02, 5.0, start=5.0)
    assert s["speed_rise_time_90_s"] == pytest.approx(4.5)
    assert s["speed_overshoot_pct"] == pytest.approx(10.0)


def test_a_start_at_the_target_is_no_step():
    t = np.arange(0, 10, DT)
    s = step_response(t, np.full_like(t, 5.0), 5.0, 0.02, 5.0, start=5.0)
    assert "speed_rise_time_90_s" not in s and "speed_overshoot_pct" not in s
    assert s["speed_settling_time_2pct_s"] == 0.0 and s["speed_steady_state_error_mps"] == 0.0


def test_the_scorecard_takes_the_step_from_the_speed_at_the_tasks_start():
    """A speed task that finds the car at 10 m/s and slows it to 5 m/s in a straight ramp of 1 m/s^2: 90 % of
    the step is 4.5 m/s down, at 4.5 s; nothing overshoots."""
    t = np.arange(0, 20, DT)
    v = np.maximum(10.0 - t, 5.0)
    log = _log(t, x=np.cumsum(v) * DT, vx=v, target_speed=np.full_like(t, 5.0))
    m = scorecard(log, Scenario(name="v", task=TaskSpec(speed=5.0)), None, 0.0)
    assert m["speed_rise_time_90_s"] == pytest.approx(4.5)
    assert m["speed_overshoot_pct"] == 0.0


def test_overshoot_and_a_speed_that_never_settles():
    t = np.arange(0, 20, DT)
    v = 10.0 + 1.0 * np.sin(t)  # +-10 % forever
    s = step_response(t, v, 10.0, 0.02, 5.0)
    assert s["speed_overshoot_pct"] == pytest.approx(10.0, abs=0.01)
    assert "speed_settling_time_2pct_s" not in s  # never settles: the scorecard says null


def test_straight_path_with_a_constant_offset_and_a_circle():
    """Driving 0.3 m left of a straight line: lateral RMS = max = p95 = 0.3, heading error 0."""
    t = np.arange(0, 10, DT)
    x = 5.0 * t
    log = _log(t, x=x, y=np.full_like(t, 0.3), vx=np.full_like(t, 5.0), target_speed=np.full_like(t, 5.0))
    path = Trajectory.from_points([(-10, 0), (100, 0)])
    scenario = Scenario(name="s", task=TaskSpec(course=((0, 0), (1, 0)), speed=5.0))
    m = scorecard(log, scenario, path, 0.0)
    assert set(m) == set(SCORECARD_KEYS)
    assert m["lateral_error_rms_m"] == pytest.approx(0.3)
    assert m["lateral_error_max_m"] == pytest.approx(0.3) and m["lateral_error_p95_m"] == pytest.approx(0.3)
    assert m["heading_error_rms_rad"] == pytest.approx(0.0)
    assert m["distance_m"] == pytest.approx(5.0 * t[-1])
    assert m["realtime_factor"] is None and m["wall_time_s"] is None  # timing is the runner's
    assert m["speed_error_rms_mps"] == pytest.approx(0.0)
    assert m["longitudinal_jerk_rms_mps3"] == pytest.approx(0.0, abs=1e-9)
    assert m["speed_rise_time_90_s"] is None  # not a speed step
    assert m["pose_error_rms_m"] is None  # exact pose


def test_circle_lateral_acceleration_is_v2_over_r():
    v, r = 8.0, 20.0
    t = np.arange(0, 10, DT)
    yaw = v / r * t
    log = _log(t, x=r * np.sin(yaw), y=r * (1 - np.cos(yaw)), yaw=yaw, vx=np.full_like(t, v),
               steer=np.full_like(t, 0.1))
    m = scorecard(log, Scenario(name="c", task=TaskSpec(speed=v)), None, 0.0)
    assert m["lateral_accel_max_mps2"] == pytest.approx(v * v / r, rel=1e-3)
    assert m["steering_rate_rms_radps"] == pytest.approx(0.0)
    assert m["lateral_error_rms_m"] is None  # no path


def test_expectations():
    m = {"completed": True, "lateral_error_rms_m": 0.2, "pose_error_rms_m": None}
    assert check_expectations(m, {"completed": True, "lateral_error_rms_m": Bound(max=0.3)}) == []
    fails = check_expectations(m, {"completed": False, "lateral_error_rms_m": Bound(min=0.25, max=0.3),
                                   "pose_error_rms_m": Bound(max=1.0)})
    assert fails == ["completed: expected false, got True", "lateral_error_rms_m: 0.2 is outside min 0.25 and max 0.3",
                     "pose_error_rms_m: None is outside max 1"]


# -- completion: judged on the track against the path, with the stated tolerances ---------------------------

LINE = Trajectory.from_points([(float(x), 0.0) for x in range(101)])  # 100 m east, a waypoint a metre
PATH_TASK = Scenario(name="p", task=TaskSpec(course=((0, 0), (100, 0)), speed=5.0))


def _drive(*legs, step=0.1) -> np.ndarray:
    """Points every ``step`` [m] along straight legs between the corners given."""
    pts = [np.asarray(legs[0], float)]
    for a, b in itertools.pairwise(legs):
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = max(1, round(np.hypot(*(b - a)) / step))
        pts += [a + (b - a) * k / n for k in range(1, n + 1)]
    return np.array(pts)


def _at_rest(xy: np.ndarray) -> np.ndarray:
    return np.r_[np.full(len(xy) - 1, 5.0), 0.0]


def test_a_drive_to_the_end_completes():
    """0.3 m beside the line to its end, stopping there: 0.3 m from the end, all of it covered."""
    xy = _drive((0, 0.3), (100, 0.3))
    c = completion(PATH_TASK, xy, _at_rest(xy), LINE)
    assert c == {"completed": True, "incomplete_reason": None, "end_error_m": pytest.approx(0.3),
                 "path_progress": 1.0, "waypoints_skipped": 0}


def test_stopping_short_within_the_end_tolerance_completes():
    xy = _drive((0, 0), (99.5, 0))
    c = completion(PATH_TASK, xy, _at_rest(xy), LINE)
    assert c["completed"] and c["end_error_m"] == pytest.approx(0.5) and c["waypoints_skipped"] == 0


def test_leaving_the_path_halfway_is_incomplete_and_says_why():
    """Along the line to x = 50, then 35 m north: covered up to 50 m plus the 2 m tolerance; waypoints at
    x = 53..100 skipped; 61 m from the end."""
    xy = _drive((0, 0), (50, 0), (50, 35))
    c = completion(PATH_TASK, xy, _at_rest(xy), LINE)
    assert c["completed"] is False
    assert c["path_progress"] == pytest.approx(0.52)
    assert c["waypoints_skipped"] == 48
    assert c["end_error_m"] == pytest.approx(math.hypot(50, 35))
    assert "covered 52% of the path within 2 m (needs 95%)" in c["incomplete_reason"]
    assert "ended 61 m from the end of the path (tolerance 1 m)" in c["incomplete_reason"]


def test_still_moving_at_the_end_is_incomplete():
    xy = _drive((0, 0), (100, 0))
    c = completion(PATH_TASK, xy, np.full(len(xy), 5.0), LINE)
    assert c["completed"] is False and c["incomplete_reason"].startswith("still moving at 5 m/s")


def test_a_cut_corner_is_not_covered():
    """On the L (0, 0) -> (50, 0) -> (50, 50), the chord from (40.5, 0) to (50, 9.5): a point (40.5 + u, u) of
    it is u from the first leg (at s = 40.5 + u) and 9.5 - u from the second (at s = 50 + u), so with a 2 m
    tolerance the arc from 42.5 + 2 to 57.5 - 2 m is not covered (11 of 100 m) nor the 11 waypoints on it."""
    corner = Trajectory.from_points([(float(x), 0.0) for x in range(50)] + [(50.0, float(y)) for y in range(51)])
    covered, reached = coverage(corner, _drive((0, 0), (40.5, 0), (50, 9.5), (50, 50), step=0.01), 2.0)
    assert covered == pytest.approx(89.0, abs=0.05)
    assert np.flatnonzero(~reached).tolist() == list(range(45, 56))


def test_driving_the_path_backwards_covers_nothing():
    xy = _drive((100, 0), (0, 0))
    covered, reached = coverage(LINE, xy, 2.0)
    assert covered == 0.0 and not reached.any()


def test_go_to_needs_only_the_target():
    task = Scenario(name="g", task=TaskSpec(go_to=(30.0, 40.0), speed=5.0), metrics=MetricsSpec(end_tolerance=0.5))
    line = Trajectory.from_points([(0, 0), (30, 40)])
    xy = _drive((0, 0), (0, 40), (29.8, 40))  # not along the line, but ends 0.2 m from the target
    assert completion(task, xy, _at_rest(xy), line)["completed"] is True
    xy = _drive((0, 0), (29, 40))
    c = completion(task, xy, _at_rest(xy), line)
    assert c["incomplete_reason"] == "ended 1 m from the target (tolerance 0.5 m)"


def test_a_speed_task_completes_at_its_speed_unless_it_breaks_down():
    xy = _drive((0, 0), (10, 0))
    task = Scenario(name="v", task=TaskSpec(speed=5.0))
    at_speed = np.full(len(xy), 5.0)
    assert completion(task, xy, at_speed, None)["completed"] is True
    c = completion(task, xy, at_speed, None, broke_down="the watchdog stopped the car")
    assert c == {"completed": False, "incomplete_reason": "the watchdog stopped the car"}


def test_a_speed_task_that_ends_off_its_speed_is_incomplete():
    """Ordered 5 m/s: ending at rest (a car that never moved, or stopped) or at 4.8 m/s (4 % short, outside the
    2 % band) did not do it; 4.95 m/s (1 %) did."""
    xy = _drive((0, 0), (10, 0))
    task = Scenario(name="v", task=TaskSpec(speed=5.0))
    c = completion(task, xy, _at_rest(xy), None)
    assert c == {"completed": False, "incomplete_reason": "ended at 0 m/s, not within 2% of the 5 m/s target"}
    assert completion(task, xy, np.full(len(xy), 4.8), None)["completed"] is False
    assert completion(task, xy, np.full(len(xy), 4.95), None)["completed"] is True
    t = np.arange(0, 10, DT)  # the whole scorecard of a car that stood still
    m = scorecard(_log(t, target_speed=np.full_like(t, 5.0)), task, None, 0.0)
    assert m["completed"] is False and m["speed_settling_time_2pct_s"] is None


def test_a_nan_state_or_a_cut_log_is_incomplete():
    t = np.arange(0, 2, DT)
    log = _log(t, x=5.0 * t, vx=np.full_like(t, 5.0))
    task = Scenario(name="v", task=TaskSpec(speed=5.0))
    assert scorecard(log, task, None, 0.0, truncated=True)["incomplete_reason"] == "the recording was cut short"
    log.rows[-1, COLUMNS.index("x")] = math.nan
    assert scorecard(log, task, None, 0.0)["completed"] is False


def test_timing_keys():
    assert timing(34.0, 2.0, 0.02, 0.5) == {"wall_time_s": 2.0, "loop_wall_time_s": 0.02, "load_time_s": 0.5,
                                            "realtime_factor": pytest.approx(1700.0)}


def _rectangle(yaw: float, half_length: float, half_width: float) -> np.ndarray:
    """A box about the origin turned by ``yaw``, its corners counter-clockwise."""
    c, s = math.cos(yaw), math.sin(yaw)
    corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)]) * (half_length, half_width)
    return np.column_stack([c * corners[:, 0] - s * corners[:, 1], s * corners[:, 0] + c * corners[:, 1]])


@settings(deadline=None, max_examples=200)
@given(pose=st.tuples(*[st.floats(-6, 6)] * 2, st.floats(-math.pi, math.pi)), sides=st.integers(3, 16),
       size=st.tuples(st.floats(0.2, 3), st.floats(0.2, 3), st.floats(0.1, 2)), car_yaw=st.floats(-math.pi, math.pi))
def test_convex_gap_is_shapelys_distance_between_a_car_box_and_a_polygon(pose, sides, size, car_yaw):
    car = _rectangle(car_yaw, size[0], size[1])
    k = np.arange(sides) * 2 * np.pi / sides
    cone = np.column_stack([pose[0] + size[2] * np.cos(k + pose[2]), pose[1] + size[2] * np.sin(k + pose[2])])
    expected = shapely.Polygon(car).distance(shapely.Polygon(cone))
    assert convex_gap(car, cone) == pytest.approx(expected, abs=1e-9)
    assert convex_gap(car[None, None], cone[None, None]).shape == (1, 1)  # broadcast over leading axes


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pi_ff_speed_10", "course_30kmh_ekf", "commonroad_tutorial", "planned_cones_30kmh",
                                  "course_3d_obstacles"])
def test_the_keys_a_scenario_never_measures_are_none_in_its_run(name):
    from vilma.scenario.runner import run
    from vilma.scenario.spec import load_scenario

    scenario = load_scenario(name, {"duration": "4"})
    metrics = run(scenario).metrics
    never = unmeasured(scenario)
    assert never and all(metrics[k] is None for k in never), [k for k in never if metrics[k] is not None]
