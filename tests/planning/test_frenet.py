import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.planning.frenet import FrenetFrame, FrenetState, frame_pose, frenet_motion
from vilma.trajectory import Trajectory

R = 30.0


def _arc(radius=R, n=60, arc=math.pi):
    """A left turn of ``radius`` [m] from the origin heading +x (centre at (0, radius))."""
    a = np.linspace(0.0, arc, n)
    return Trajectory.from_points(np.column_stack([radius * np.sin(a), radius * (1 - np.cos(a))]))


CIRCLE = FrenetFrame(_arc(n=200))


def _s_curve():
    x = np.linspace(0.0, 120.0, 25)
    return Trajectory.from_points(np.column_stack([x, 8.0 * np.sin(x / 15.0)]))


@pytest.mark.parametrize("reference", [_arc(), _s_curve()], ids=["arc", "s-curve"])
def test_round_trip_xy_to_sd_to_xy_is_exact_on_a_curved_path(reference):
    frame = FrenetFrame(reference)
    s = np.random.default_rng(0).uniform(0.0, frame.length, 2000)
    d = np.random.default_rng(1).uniform(-5.0, 5.0, 2000)  # well inside the radius of curvature
    x, y = frame.to_cartesian(s, d)
    s2, d2 = frame.to_frenet(x, y)
    x2, y2 = frame.to_cartesian(s2, d2)
    assert np.hypot(x2 - x, y2 - y).max() < 1e-6
    assert s2 == pytest.approx(s, abs=1e-6) and d2 == pytest.approx(d, abs=1e-6)


def test_the_frame_of_a_circle_is_its_arc_length_radius_and_curvature():
    frame = CIRCLE
    assert frame.length == pytest.approx(R * math.pi, rel=1e-6)
    phi = np.array([0.3, 1.0, 2.5])
    # a point at radius R - r from the centre is r left of a left turn, at arc length R phi
    r = 2.0
    s, d = frame.to_frenet((R - r) * np.sin(phi), R - (R - r) * np.cos(phi))
    assert s == pytest.approx(R * phi, rel=1e-6) and d == pytest.approx(r, abs=1e-6)
    x, y, heading, k, dk = frame.pose(R * 1.0)
    assert (x, y, heading) == pytest.approx((R * math.sin(1.0), R * (1 - math.cos(1.0)), 1.0), abs=1e-6)
    assert k == pytest.approx(1 / R, rel=1e-4) and dk == pytest.approx(0.0, abs=1e-5)


def test_a_straight_reference_is_the_plane_and_goes_on_straight_past_its_ends():
    frame = FrenetFrame(Trajectory.from_points([(0.0, 0.0), (0.0, 0.0), (10.0, 0.0)]))  # the repeated point dropped
    s, d = frame.to_frenet([-5.0, 3.0, 14.0], [1.0, -2.0, 0.5])
    assert s == pytest.approx([-5.0, 3.0, 14.0]) and d == pytest.approx([1.0, -2.0, 0.5])
    assert frame.pose(14.0)[:4] == pytest.approx((14.0, 0.0, 0.0, 0.0))


@settings(deadline=None)  # the first example loads the compiled code
@given(st.floats(1.0, 90.0), st.floats(-3.0, 3.0), st.floats(-1.0, 1.0), st.floats(-0.5, 0.5),
       st.floats(-2.0, 2.0), st.floats(-0.5, 0.5))
def test_the_state_of_a_car_is_the_inverse_of_its_frenet_motion(s, d, s_dot_rel, s_ddot, d_dot, d_ddot):
    frame = CIRCLE
    s_dot = 5.0 + 4.0 * s_dot_rel
    _, _, theta, k, dk = frame_pose(frame.arrays, s)
    (cx,), (cy,) = frame.to_cartesian([s], [d])
    yaw, v, a, kappa = frenet_motion(theta, k, dk, s_dot, s_ddot, d, d_dot, d_ddot)
    back = frame.state(cx, cy, yaw, v, a, kappa)
    assert back == pytest.approx(FrenetState(s, s_dot, s_ddot, d, d_dot, d_ddot), abs=1e-6)


def test_a_car_on_a_straight_reference_at_an_angle():
    frame = FrenetFrame(Trajectory.from_points([(0.0, 0.0), (50.0, 0.0)]))
    v, yaw = 10.0, 0.1
    st_ = frame.state(5.0, 1.0, yaw, v, accel=2.0)
    assert st_ == pytest.approx((5.0, v * math.cos(yaw), 2.0 * math.cos(yaw), 1.0, v * math.sin(yaw),
                                 2.0 * math.sin(yaw)))


def test_a_curvature_follows_from_a_circle_driven_at_an_offset():
    # driving the circle of radius R - d concentric with a left-turn reference: curvature 1 / (R - d)
    frame = CIRCLE
    _, _, theta, k, dk = frame.pose(40.0)
    yaw, v, a, kappa = frenet_motion(theta, k, dk, 10.0, 0.0, 2.0, 0.0, 0.0)
    assert (yaw, v, a, kappa) == pytest.approx((theta, 10.0 * (R - 2.0) / R, 0.0, 1 / (R - 2.0)), rel=1e-4,
                                               abs=1e-3)  # the spline's curvature ripple of ~1e-5 1/m^2


def test_a_reference_needs_two_distinct_points():
    with pytest.raises(ValueError, match="at least two distinct points"):
        FrenetFrame(Trajectory.from_points([(1.0, 2.0), (1.0, 2.0)]))
