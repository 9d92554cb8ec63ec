"""The local planning's velocity target (the route's speed, braked to from ahead) and its predictions."""

import math

import numpy as np
import pytest

from vilma.control.driver import Driver
from vilma.control.local_planning import LocalPlanning, default_planner
from vilma.core.messages import PoseEstimate
from vilma.perception import Track
from vilma.trajectory import Arrival, Trajectory
from vilma.vehicle.params import vilma
from vilma.world.lanes import Lanes

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


def test_tracks_moving_on_a_known_lane_are_predicted_along_each_way_on_and_the_others_straight_on():
    # a lane east to 20 m forking into one on east and one north; a car on it at 10 m, 5 m/s, and one at walking pace
    east, on, north = ([[0.0, 0.0], [20.0, 0.0]], [[20.0, 0.0], [60.0, 0.0]], [[20.0, 0.0], [20.0, 40.0]])
    lanes = Lanes.of([east, on, north], [[3.5, 3.5]] * 3, [[1, 2], [], []])
    path = Trajectory(np.column_stack([np.arange(0.0, 100.0), np.full(100, -3.5)]), np.full(100, 10.0))
    params = default_planner(CAR)
    local = LocalPlanning(params, "truth", None, path, Driver(CAR, step=0.01), lanes=lanes)
    moving = Track(1, 10.0, 0.0, 0.0, 5.0, 0.0, 4.5, 1.8, np.eye(4), 1.0)
    slow = Track(2, 5.0, 0.0, 0.0, 0.5, 0.0, 4.5, 1.8, np.eye(4), 1.0)
    local.tracks = [moving, slow]
    tracks, predicted = local._predict(params)
    assert [t.id for t in tracks] == [1, 1, 2]
    s = 5.0 * params.horizon  # 15 m on: 10 m to the fork, 5 m past it
    np.testing.assert_allclose(predicted[0, -1, :3], [25.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(predicted[1, -1, :3], [20.0, s - 10.0, math.pi / 2], atol=1e-9)
    np.testing.assert_allclose(predicted[2, -1, :2], [5.0 + 0.5 * params.horizon, 0.0])  # straight on


def test_the_goal_regions_window_is_dropped_once_the_car_is_in_it():
    # a CommonRoad goal is reached once: a window left to aim at would keep pulling the car into it (or hold it
    # there) while what is left is the stop at the route's end
    path = Trajectory(np.column_stack([np.arange(0.0, 200.0), np.zeros(200)]), np.full(200, 10.0))
    window = Arrival((40.0, 60.0), (3.0, 5.0))
    driver = Driver(CAR, step=0.01)
    local = LocalPlanning(default_planner(CAR), "truth", None, path, driver, arrivals=(window,))
    for t, x, left in ((2.0, 30.0, (window,)), (4.0, 50.0, ())):
        driver.estimator.estimate = PoseEstimate(round(t * 1e9), x, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 0.0)
        local.cycle(t)
        assert local.arrivals == left
