"""The objects sensor: the scene's true obstacles within its reach, with the noise its parameters give."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vilma.core.messages import ObjectList, ObjectState
from vilma.sensors.base import Samples, sensor_rng
from vilma.sensors.objects import ObjectsParams, ObjectsSensor
from vilma.sensors.scene import Scene
from vilma.vehicle.state import VehicleState

L, W = 4.5, 1.8  # a car's length and width [m]
CAR = np.array([[L / 2, -W / 2], [L / 2, W / 2], [-L / 2, W / 2], [-L / 2, -W / 2]])


def scene(*states, present=None, dt=0.1) -> Scene:
    """Boxes of CAR size, ids 10, 11, ..., each standing in one state (x, y, yaw, speed) at two time steps."""
    s = np.array([[st, st] for st in states], float)
    return Scene(np.arange(10, 10 + len(states)), np.zeros(len(states), bool), np.repeat(CAR[None], len(states), 0),
                 s, np.ones(s.shape[:2], bool) if present is None else np.array(present), dt)


def lists(sc: Scene, n=1, car=VehicleState(), seed=0, **params) -> list[ObjectList]:
    """``n`` object lists of the car in ``car``'s state at sim time 0."""
    sensor = ObjectsSensor(ObjectsParams(**params), sc)
    sensor.reset(sensor_rng(seed, sensor.name))
    z = np.repeat(car.to_array()[None], n, 0)
    return sensor.scan(Samples(np.arange(n), z, np.zeros((n, 6))), np.zeros(n, np.int64))


def test_without_noise_an_object_is_reported_exactly():
    (msg,) = lists(scene((12.0, -3.0, 0.4, 8.5)), position_noise=0.0, speed_noise=0.0)
    (o,) = msg.objects
    assert o == ObjectState(10, 12.0, -3.0, o.yaw, 8.5, L, W)
    assert o.yaw == pytest.approx(0.4, abs=1e-15)  # wrapped to (-pi, pi]: a rounding of pi's


def test_nothing_beyond_the_range_of_the_car():
    r = 30.0
    car = VehicleState(x=100.0, y=50.0)
    near, far = (100.0 + r - 0.01, 50.0, 0, 0), (100.0, 50.0 - r - 0.01, 0, 0)
    (msg,) = lists(scene(near, far), car=car, range=r, position_noise=0.0, speed_noise=0.0)
    assert [o.id for o in msg.objects] == [10]


def test_an_absent_object_is_not_reported():
    (msg,) = lists(scene((5, 0, 0, 0), (6, 0, 0, 0), present=[[False, False], [True, True]]))
    assert [o.id for o in msg.objects] == [11]


def test_position_and_speed_have_the_given_standard_deviations():
    truth, n, sp, sv = (12.0, -3.0, 0.4, 8.5), 4000, 0.3, 0.2
    got = np.array([[o.x, o.y, o.yaw, o.speed] for m in lists(scene(truth), n, position_noise=sp, speed_noise=sv)
                    for o in m.objects])
    assert len(got) == n
    sigma = np.array([sp, sp, 0.0, sv])
    # the mean within 4 standard errors, the spread within 4 of its own (sigma / sqrt(2 n)); yaw exact
    np.testing.assert_allclose(got.mean(axis=0), truth, atol=float(4 * sp / math.sqrt(n)))
    np.testing.assert_allclose(got.std(axis=0, ddof=1), sigma, atol=float(4 * sp / math.sqrt(2 * n)))
    assert np.corrcoef(got[:, 0], got[:, 1])[0, 1] == pytest.approx(0.0, abs=4 / math.sqrt(n))  # independent axes


def test_the_same_seed_gives_the_same_noise_and_another_seed_other_noise():
    sc = scene((12.0, -3.0, 0.4, 8.5))
    assert lists(sc, 3, seed=1) == lists(sc, 3, seed=1) != lists(sc, 3, seed=2)


@pytest.mark.parametrize("field, value", [("range", 0.0), ("rate_hz", -1.0), ("position_noise", -0.1),
                                          ("speed_noise", math.nan)])
def test_bad_parameters_are_one_line_errors_naming_the_field(field, value):
    with pytest.raises(ValueError, match=f"objects {field} must be") as e:
        ObjectsParams(**{field: value})
    assert "\n" not in str(e.value)
