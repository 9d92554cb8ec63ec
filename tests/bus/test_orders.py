"""What every order is checked for: its speed, goal and points."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.bus.orders import MAX_REACH, check_goal, check_points, order_speed

TOP = 50.0
"""A car's top speed [m/s]."""


@given(st.floats(), st.booleans())
def test_a_speed_is_taken_above_0_or_at_0_for_a_stop_up_to_the_top_speed(speed, stop):
    if (speed >= 0 if stop else speed > 0) and speed <= TOP:
        assert order_speed(speed, TOP, stop) == speed
    else:
        with pytest.raises(ValueError, match=r"^speed .* m/s: give .*, up to the car's top speed, 50 m/s$"):
            order_speed(speed, TOP, stop)


@given(st.floats(), st.floats())
def test_a_goal_is_a_finite_point_within_reach_of_the_car(x, y):
    car = (100.0, -100.0)
    near = math.isfinite(x) and math.isfinite(y) and math.dist((x, y), car) <= MAX_REACH
    try:
        check_goal(x, y, car)
    except ValueError as e:
        assert not near and "\n" not in str(e)
    else:
        assert near


@pytest.mark.parametrize(("points", "speeds", "error"), [
    ([(0.0, 0.0), (0.0, 0.0)], None, "path points must be 2 or more distinct finite [x, y] pairs [m]"),
    ([(0.0, 0.0)], None, "path points must be 2 or more distinct finite [x, y] pairs [m]"),
    ([(0.0, 0.0), (math.nan, 1.0)], None, "path points must be 2 or more distinct finite [x, y] pairs [m]"),
    ([(0.0, 0.0), (1e300, 0.0)], None, "path points over 100000 m from the car; send the path near the car"),
    ([(0.0, 0.0), (1.0, 0.0)], [1.0, -1.0], "path speeds must be from 0 to the car's top speed, 50 m/s"),
    ([(0.0, 0.0), (1.0, 0.0)], [1.0, TOP + 1], "path speeds must be from 0 to the car's top speed, 50 m/s"),
])
def test_points_refused(points, speeds, error):
    with pytest.raises(ValueError) as e:
        check_points(np.array(points), None if speeds is None else np.array(speeds), (0.0, 0.0), TOP, "path")
    assert str(e.value) == error


def test_points_taken_may_repeat_and_end_at_rest():
    check_points(np.array([(0.0, 0.0), (0.0, 0.0), (5.0, 0.0)]), np.array([TOP, 1.0, 0.0]), (0.0, 0.0), TOP, "path")
