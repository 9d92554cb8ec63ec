"""The LQR steering controller against its source's anchor and the closed-loop poles of its model."""

import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg

from vilma.control.path.lqr import RESET, LqrParams, lqr_consts, lqr_step
from vilma.trajectory import Trajectory
from vilma.trajectory.course import spline_course
from vilma.vehicle.params import vilma

# PythonRobotics' lqr_steer_control.py: its course, wheelbase, time tick, target speed, steering limit, Q = I, R = 1
AX = [0.0, 6.0, 12.5, 10.0, 7.5, 3.0, -1.0]
AY = [0.0, -3.0, -5.0, 6.5, 3.0, 5.0, -2.0]
WHEELBASE, DT, TARGET_SPEED, MAX_STEER = 0.5, 0.1, 10.0 / 3.6, math.radians(45.0)
ANCHOR_RMS = 0.111
"""Lateral RMS [m] of PythonRobotics' LQR steering control on that course: its lqr_steer_control.py run at commit
b38c510 (2026-06), its own error (signed distance to the nearest spline sample) over the drive to the goal. The
issue quoted 0.14 m; the run gives less, and that is the bar here."""


def _car(wheelbase=WHEELBASE, max_steer=MAX_STEER, cg_to_rear=1e-3):
    """vilma's car resized: the anchor's model tracks the rear axle, so here the centre of mass sits just ahead."""
    return dataclasses.replace(vilma(), cg_to_front=wheelbase - cg_to_rear, cg_to_rear=cg_to_rear,
                               max_steer=max_steer)


def _state():
    return np.array(RESET)


def _drive(path, car, params, speed, x, y, yaw, seconds, accel_gain=None, goal=None):
    """PythonRobotics' loop: the rear-axle kinematic bicycle, Euler at the control period, P speed control.

    Returns the rear axle's positions (n, 2) and the controller's passed-end flags (n,).
    """
    c, st, pa, dt, lr = lqr_consts(params, car), _state(), path.arrays, params.period, car.cg_to_rear
    v = 0.0 if accel_gain else speed
    xy, ends = [], []
    for _ in range(round(seconds / dt)):
        steer, end = lqr_step(c, st, pa, x + lr * math.cos(yaw), y + lr * math.sin(yaw), yaw, v, 0.0)
        steer = min(max(steer, -car.max_steer), car.max_steer)
        x, y = x + v * math.cos(yaw) * dt, y + v * math.sin(yaw) * dt
        yaw += v / car.wheelbase * math.tan(steer) * dt
        if accel_gain:
            v += accel_gain * (speed - v) * dt
        xy.append((x, y))
        ends.append(end)
        if goal is not None and math.hypot(x - goal[0], y - goal[1]) <= 0.3:
            break
    return np.array(xy), np.array(ends)


def test_reproduces_the_python_robotics_anchor():
    # its cubic spline course: natural, chord-length parameter, a sample every 0.1 m of it (ds = 0.1)
    path = spline_course(list(zip(AX, AY, strict=True)), spacing=0.1)
    params = LqrParams(period=DT, q_lateral=1.0, q_lateral_rate=1.0, q_heading=1.0, q_heading_rate=1.0, r_steer=1.0,
                       tyre_slip=False)
    xy, _ = _drive(path, _car(), params, TARGET_SPEED, 0.0, 0.0, 0.0, 500.0, accel_gain=1.0, goal=(AX[-1], AY[-1]))
    assert math.hypot(*(xy[-1] - (AX[-1], AY[-1]))) <= 0.3  # reached the goal, as the anchor does
    rms = float(np.sqrt(np.mean(path.project_track(xy)[:, 1] ** 2)))
    print(f"LQR on PythonRobotics' course: lateral RMS {rms:.3f} m (anchor {ANCHOR_RMS} m)")
    assert rms <= ANCHOR_RMS * 1.1


def _sampled_loop(speed, period, wheelbase):
    """The rear-axle bicycle, linearised and sampled at ``period``, under the LQR law with Q = I, R = 1 (the gain
    solved here from the module docstring's model), its rates the errors' differences: z = [e, th_e, e', th_e']
    (primes: the previous period's), z[k+1] = M z[k]."""
    a = np.array([[1.0, period, 0.0, 0.0], [0.0, 0.0, speed, 0.0], [0.0, 0.0, 1.0, period], [0.0, 0.0, 0.0, 0.0]])
    b = np.array([[0.0], [0.0], [0.0], [speed / wheelbase]])
    x = scipy.linalg.solve_discrete_are(a, b, np.eye(4), np.eye(1))
    k0, k1, k2, k3 = np.linalg.solve(b.T @ x @ b + 1.0, b.T @ x @ a)[0]
    steer = -np.array([k0 + k1 / period, k2 + k3 / period, -k1 / period, -k3 / period])  # steer = steer . z
    return np.array([[1.0, speed * period, 0.0, 0.0], [*(speed / wheelbase * period * steer + [0, 1, 0, 0])],
                     [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])


def test_an_offset_on_a_straight_decays_as_the_closed_loop_poles_say():
    car, params, speed, offset = _car(vilma().wheelbase, vilma().max_steer), LqrParams(), 5.0, 0.5
    m = _sampled_loop(speed, params.period, car.wheelbase)
    poles = np.linalg.eigvals(m)
    # stable, and the slowest pole real and positive: the error decays as p^k without ringing
    slowest = poles[np.argmax(abs(poles))]
    assert abs(slowest) < 1.0 and slowest.imag == 0.0 and slowest.real > 0.0
    tau = -params.period / math.log(slowest.real)
    path = Trajectory.from_points([(0.0, 0.0), (200.0, 0.0)])
    xy, _ = _drive(path, car, params, speed, 0.0, offset, 0.0, 8 * tau)
    e = path.project_track(xy)[:, 1]
    z, predicted = np.array([offset, 0.0, offset, 0.0]), []  # no rates on the first period
    for _ in e:
        z = m @ z
        predicted.append(z[0])
    # the nonlinear bicycle (sin, tan) follows the linear prediction to 0.2 % of the offset, and never overshoots
    assert np.abs(e - predicted).max() < 0.002 * offset
    assert e.min() > -0.01 * offset and abs(e[-1]) < 0.01 * offset


def test_zero_error_on_a_straight_gives_zero_steer():
    straight = Trajectory.from_points([(0.0, 0.0), (50.0, 0.0)])
    c = lqr_consts(LqrParams(), vilma())
    assert lqr_step(c, _state(), straight.arrays, 10.0, 0.0, 0.0, 5.0, 0.0) == (0.0, False)


@pytest.mark.parametrize("tyre_slip", [False, True])
def test_riding_a_circle_gives_the_steady_state_steer(tyre_slip):
    car, r, v = vilma(), 30.0, 8.0
    a = np.linspace(-math.pi / 2, 0.0, 2000)
    circle = Trajectory.from_points(np.c_[r * np.cos(a), r * np.sin(a)])
    # steady cornering of the single-track model (kinematic without slip): the centre of mass rides the circle
    # with sideslip atan(lr / r) - m lf v^2 / (L C_r r) and the wheels at atan(L / r) + K v^2 / r
    rear_slip = car.mass * car.cg_to_front * v * v / (car.wheelbase * car.cornering_stiffness_rear * r)
    sideslip = math.atan(car.cg_to_rear / r) - tyre_slip * rear_slip
    expected = math.atan(car.wheelbase / r) + tyre_slip * car.understeer_gradient * v * v / r
    c = lqr_consts(LqrParams(tyre_slip=tyre_slip), car)
    yaw = math.pi / 4 - sideslip  # the tangent at -pi/4, less the sideslip
    steer, end = lqr_step(c, _state(), circle.arrays, r * math.cos(-math.pi / 4), r * math.sin(-math.pi / 4), yaw, v,
                          0.0)
    assert steer == pytest.approx(expected, abs=1e-3) and not end


def test_passed_end_once_the_car_reaches_the_last_point():
    path = Trajectory.from_points([(0.0, 0.0), (20.0, 0.0)])
    xy, ends = _drive(path, vilma(), LqrParams(), 5.0, 0.0, 0.0, 0.0, 6.0)
    cg_x = np.r_[0.0, xy[:-1, 0]] + vilma().cg_to_rear  # where the centre of mass was at each step
    assert not ends[cg_x < 20.0].any() and ends[cg_x >= 20.0].all() and ends.any()


def test_steering_is_clamped_to_the_car():
    car = vilma()
    path = Trajectory.from_points([(0.0, 0.0), (50.0, 0.0)])
    steer, _ = lqr_step(lqr_consts(LqrParams(), car), _state(), path.arrays, 10.0, -20.0, 0.0, 5.0, 0.0)
    assert steer == car.max_steer


@pytest.mark.parametrize(("field", "value", "message"), [
    ("r_steer", 0.0, "lqr r_steer must be a finite number > 0, got 0.0"),
    ("q_heading", -1.0, "lqr q_heading must be a finite number >= 0, got -1.0"),
    ("window", 0, "lqr window must be at least 1 segment, got 0"),
    ("speed_resolution", 50.0, "lqr speed_resolution 50.0 must be <= max_speed 40.0"),
])
def test_bad_params_are_named(field, value, message):
    with pytest.raises(ValueError, match="^" + message.replace(".", r"\.") + "$"):
        LqrParams(**{field: value})
