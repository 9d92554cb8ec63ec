"""The local planning's velocity target: the route's speed, braked to from ahead."""

import math

import numpy as np
import pytest

from vilma.control.driver import Driver
from vilma.control.local_planning import LocalPlanning, default_planner
from vilma.trajectory import Trajectory
from vilma.vehicle.params import vilma

CAR = vilma()


def test_the_target_is_the_lowest_speed_that_brakes_comfortably_to_the_routes_speed_ahead():
    # 10 m/s along +x, 4 m/s from 40 m to 60 m (a bend, say), 10 m/s after
    x = np.arange(0.0, 200.5, 0.5)
    speed = np.where((x >= 40.0) & (x <= 60.0), 4.0, 10.0)
    path = Trajectory(np.column_stack([x, np.zeros_like(x)]), speed)
    local = LocalPlanning(default_planner(CAR), "truth", None, path, Driver(CAR, step=0.01))
    b = CAR.actuators.stop_deceleration
    assert local._speed_ahead(0.0, 0.0) == pytest.approx(10.0)  # from 40 m away 4 m/s is sqrt(16 + 240) > 10 off
    assert local._speed_ahead(35.0, 0.0) == pytest.approx(math.sqrt(4.0**2 + 2 * b * 5.0))  # 5 m before the bend
    assert local._speed_ahead(50.0, 0.0) == pytest.approx(4.0)
    assert local._speed_ahead(190.0, 0.0) == pytest.approx(10.0)  # the route's end at its own speed
