"""Speed profiles timed to arrive in a window: checked against the kinematics of constant acceleration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vilma.trajectory import Arrival, Trajectory, arrival_profile
from vilma.trajectory.profile import CAP_STEP

LIMIT = 20.0  # [m/s] along a straight 200 m path


def _straight(limit: float = LIMIT) -> Trajectory:
    x = np.linspace(0.0, 200.0, 801)
    return Trajectory(np.c_[x, np.zeros_like(x)], np.full(len(x), limit))


def _time_at(path: Trajectory, s: float) -> float:
    """When the profile reaches arc length ``s`` [m] [s]: constant acceleration between points."""
    v = path.speed
    t = np.concatenate([[0.0], np.cumsum(2 * np.diff(path.s) / (v[:-1] + v[1:]))])
    return float(np.interp(s, path.s, t))


def test_from_rest_it_cruises_at_the_speed_that_arrives_in_the_middle_of_the_window():
    # From rest at a = 2 m/s^2 to a cruise speed c, then c: t(s) = c / a + (s - c^2 / 2a) / c, so arriving at
    # s = 100 m at t = 12 s takes c = a t - sqrt(a^2 t^2 - 2 a s) = 24 - sqrt(176) = 10.73 m/s.
    a, s, t = 2.0, 100.0, 12.0
    c = a * t - math.sqrt(a * a * t * t - 2 * a * s)
    path = arrival_profile(_straight(), 0.0, a, 2.0, (Arrival((s - 1, s + 1), (t - 0.5, t + 0.5)),))
    before = path.speed[path.s < s]
    assert before.max() == pytest.approx(c, abs=CAP_STEP)
    assert _time_at(path, s) == pytest.approx(t, abs=CAP_STEP * s / c ** 2 + 1e-9)  # |dt/dc| = s / c^2 at most
    assert np.all(np.diff(before[before < before.max() - 1e-9]) > 0)  # the ramp up from rest


def test_it_slows_down_from_the_start_speed_at_the_deceleration_given():
    # From 20 m/s down at d = 2 m/s^2 to c, then c: t(100 m) = (20 - c) / d + (100 - (400 - c^2) / 2d) / c,
    # which is 10 - c / 4 s: arriving at 8 s takes c = 8 m/s, reached after (400 - 64) / 4 = 84 m.
    d = 2.0
    path = arrival_profile(_straight(), LIMIT, 2.0, d, (Arrival((99, 101), (7.5, 8.5)),))
    assert path.speed[np.argmin(np.abs(path.s - 100))] == pytest.approx(8.0, abs=CAP_STEP)
    ramp = path.s < 83
    np.testing.assert_allclose(path.speed[ramp], np.sqrt(LIMIT ** 2 - 2 * d * path.s[ramp]), rtol=1e-12)
    assert _time_at(path, 100.0) == pytest.approx(8.0, abs=CAP_STEP * 4)  # |dt/dc| = 1/4 s per m/s


def test_a_window_the_limits_already_meet_changes_nothing_but_the_final_stop():
    d = 2.0
    path = arrival_profile(_straight(), LIMIT, 2.0, d, (Arrival((0, 200), (3.0, 4.0)),))  # in it all along
    braking = path.s > 200 - LIMIT ** 2 / (2 * d)
    assert np.all(path.speed[~braking] == LIMIT)
    np.testing.assert_allclose(path.speed[braking], np.sqrt(2 * d * (200 - path.s[braking])), rtol=1e-9)


def test_the_speed_window_is_kept_where_the_arc_window_is_met():
    path = arrival_profile(_straight(), 0.0, 2.0, 2.0, (Arrival((99, 101), (0.0, 100.0), (3.0, 5.0)),))
    v = np.interp([99.0, 101.0], path.s, path.speed)
    assert np.all((v >= 3.0) & (v <= 5.0))


def test_a_window_no_cruise_speed_reaches_gives_none():
    # 100 m in 2 s needs 50 m/s on average, over the 20 m/s limit
    assert arrival_profile(_straight(), LIMIT, 2.0, 2.0, (Arrival((99, 101), (1.0, 2.0)),)) is None
    # and a window off the path's end
    assert arrival_profile(_straight(), LIMIT, 2.0, 2.0, (Arrival((300, 310), (0.0, 100.0)),)) is None


def test_of_several_windows_the_one_with_more_slack_is_chosen():
    late = Arrival((99, 101), (9.5, 10.5))  # a cruise at 20 m/s passes s = 100 m at 5 s: needs slowing
    early = Arrival((99, 101), (4.0, 6.0))  # met at the limit, with 1 s of slack either way
    path = arrival_profile(_straight(), LIMIT, 2.0, 2.0, (late, early))
    assert _time_at(path, 100.0) == pytest.approx(5.0, abs=1e-9)


def test_a_window_passed_too_fast_at_the_limits_is_met_below_its_speed_bound():
    # at the 20 m/s limit the car is under 12 m/s in the arc window only early on and in its final stop, neither
    # at 8.0-8.2 s: it must cruise slower, and be in the window's arc and speed intervals then
    w = Arrival((20, 180), (8.0, 8.2), (0.0, 12.0))
    path = arrival_profile(_straight(), 5.0, 2.0, 2.0, (w,))
    t = np.concatenate([[0.0], np.cumsum(2 * np.diff(path.s) / (path.speed[:-1] + path.speed[1:]))])
    s = np.interp([8.0, 8.1, 8.2], t, path.s)
    assert np.all((s > 20) & (s < 180))
    assert np.all(np.interp(s, path.s, path.speed) <= 12.0)


def test_an_arrival_holds_a_car_inside_each_of_its_intervals_and_offsets_alone():
    # offsets from -1 to 1 m at s = 10 m widening to -3 to 3 m at s = 30 m: +-2 m at s = 20 m
    w = Arrival((10.0, 30.0), (1.0, 2.0), (4.0, 6.0), np.array([[10.0, 30.0], [-1.0, -3.0], [1.0, 3.0]]))
    assert w.holds(20.0, 1.5, 5.0, 2.0) and w.holds(10.0, 1.0, 4.0, -1.0) and w.holds(30.0, 2.0, 6.0, 3.0)
    for outside in ((9.9, 1.5, 5.0, 0.0), (20.0, 2.1, 5.0, 0.0), (20.0, 1.5, 6.1, 0.0), (20.0, 1.5, 5.0, 2.1)):
        assert not w.holds(*outside)
    assert Arrival((10.0, 30.0), (1.0, 2.0)).holds(20.0, 1.5, -50.0, 99.0)  # any speed and offset
