import math

import pytest

from tests.control.speed.conftest import speed_run, time_to
from vilma.control.registry import controller_type
from vilma.control.speed.pi_ff import PiFfParams
from vilma.vehicle.actuators import FORCE
from vilma.vehicle.params import VehicleParams, vilma


def make_pi_ff(vehicle: VehicleParams, params: PiFfParams | None = None):
    """The registered ``pi_ff``; its state is [reference speed, its acceleration, its jerk, integral]."""
    return controller_type("pi_ff").make(vehicle, params)


def test_beats_the_original_pid():
    t0, v0 = speed_run(controller_type("vilma_pid").make(vilma()), 10.0, seconds=40.0, delay=True)
    t, v = speed_run(make_pi_ff(vilma()), 10.0, seconds=40.0)
    assert time_to(t, v, 9.0) <= 0.6 * time_to(t0, v0, 9.0)
    assert v.max() < 10.0 * 1.01
    assert abs(v[-20:] - 10.0).max() < 0.05


def test_feed_forward_holds_speed_without_integral():
    p = vilma()
    ctrl = make_pi_ff(p, PiFfParams(kp=0.0, ki=0.0))
    ctrl.state[:] = (20.0, 0.0, 0.0, 0.0)  # reference at 20 m/s, steady
    mode, drive, brake, _ = ctrl.step(20.0, 20.0, 0.0)
    assert mode == FORCE and brake == 0.0
    assert drive == pytest.approx(p.resistance(20.0))


def test_brakes_when_slowing_and_respects_limits():
    p = vilma()
    params = PiFfParams()
    ctrl = make_pi_ff(p, params)
    brakes = [ctrl.step(0.0, 15.0, 0.0)[2] for _ in range(100)]
    assert any(b > 0 for b in brakes)
    # the request never exceeds the deceleration limit (plus the resistance it no longer needs)
    assert max(brakes) <= p.mass * params.max_decel
    # jerk limit: the reference acceleration changes by at most max_jerk * period per step
    ctrl.reset()
    a = []
    for _ in range(round(2 * params.max_accel / params.max_jerk / params.period)):
        ctrl.step(30.0, 0.0, 0.0)
        a.append(ctrl.state[1])  # the reference acceleration
    assert max(abs(x - y) for x, y in zip(a[1:], a, strict=False)) <= params.max_jerk * params.period + 1e-12
    assert math.isclose(max(a), params.max_accel)
