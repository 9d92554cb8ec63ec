import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.core.geometry import (
    heading_from_north_ccw,
    quaternion_from_euler,
    wrap_angle,
    yaw_from_heading_north_ccw,
    yaw_from_quaternion,
)

angles = st.floats(-1e4, 1e4, allow_nan=False)


@given(angles)
def test_wrap_is_in_half_open_interval_and_same_direction(a):
    w = wrap_angle(a)
    assert -math.pi < w <= math.pi
    assert math.cos(w) == pytest.approx(math.cos(a), abs=1e-9)
    assert math.sin(w) == pytest.approx(math.sin(a), abs=1e-9)


def test_wrap_edges():
    assert wrap_angle(math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)
    np.testing.assert_allclose(wrap_angle(np.array([3 * math.pi, -0.5])), [math.pi, -0.5])


@given(st.floats(-3.1, 3.1))
def test_quaternion_yaw_round_trip(yaw):
    q = quaternion_from_euler(0.0, 0.0, yaw)
    assert sum(c * c for c in q) == pytest.approx(1.0)
    assert yaw_from_quaternion(*q) == pytest.approx(yaw, abs=1e-12)


def test_original_heading_convention():
    # the original car pointed along +y at heading 0, counter-clockwise positive
    assert heading_from_north_ccw(math.pi / 2) == pytest.approx(0.0)
    assert heading_from_north_ccw(math.pi) == pytest.approx(math.pi / 2)
    assert yaw_from_heading_north_ccw(0.0) == pytest.approx(math.pi / 2)
    for h in np.linspace(-3, 3, 13):
        assert heading_from_north_ccw(yaw_from_heading_north_ccw(h)) == pytest.approx(h)
