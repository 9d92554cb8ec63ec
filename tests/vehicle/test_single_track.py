"""Physics of the planar models, checked against closed-form results from the parameters."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from tests.conftest import STEP, drive, fit_circle, physics_only
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.sim import Simulator
from vilma.vehicle.models.single_track import lateral_tyre_force
from vilma.vehicle.params import GRAVITY, bmw_320i, plant_consts, preset, vilma
from vilma.vehicle.state import BRAKE, VX, YAW, YAW_RATE, VehicleState, X, Y


def test_top_speed_where_drive_equals_drag_plus_rolling():
    p = vilma()
    # full drive force, limited by power: P / v = 1/2 rho CdA v^2 + Crr m g
    v_top = brentq(lambda v: p.max_power / v - p.resistance(v), 10.0, 200.0)
    assert v_top >= 40.0
    sim = Simulator(physics_only())
    sim.reset(VehicleState(vx=v_top - 5.0))
    sim.command(ActuatorCommand(drive=p.max_drive_force))
    sim.run_for(200.0)
    assert sim.state.vx == pytest.approx(v_top, rel=0.002)


def test_zero_to_100_kmh_with_original_power_1000():
    # vilma.blend note: "powerAmount = 1000.0 ... 0 - 100 km/h por volta de 10.8 s"
    z = drive(physics_only(), ActuatorCommand(longitudinal=Longitudinal.POWER, drive=1000.0), 20.0)
    i = int(np.argmax(z[:, VX] >= 100 / 3.6))
    assert i > 0
    assert (i + 1) * STEP == pytest.approx(10.8, rel=0.10)


def test_coasting_deceleration_from_drag_and_rolling_resistance():
    p = vilma()
    k, fr, m, v0 = 0.5 * p.air_density * p.drag_area, p.rolling_resistance * p.mass * GRAVITY, p.mass, 25.0
    t = 10.0
    # m dv/dt = -(k v^2 + Fr)  =>  v(t) = sqrt(Fr/k) tan(atan(v0 sqrt(k/Fr)) - t sqrt(k Fr)/m)
    expected = math.sqrt(fr / k) * math.tan(math.atan(v0 * math.sqrt(k / fr)) - t * math.sqrt(k * fr) / m)
    sim = Simulator(physics_only())
    sim.reset(VehicleState(vx=v0))
    sim.run_for(t)
    assert sim.state.vx == pytest.approx(expected, rel=1e-4)


@pytest.mark.parametrize("model", ["kinematic", "single_track"])
@pytest.mark.parametrize("steer", [0.2, 0.4, 0.6])
def test_low_speed_turning_radius_is_wheelbase_over_tan_steer(model, steer):
    p = vilma()
    z = drive(physics_only(model=model), ActuatorCommand(steer=steer, longitudinal=Longitudinal.ACCEL),
              30.0, initial=VehicleState(vx=1.0, steer=steer))
    # the rear axle centre moves on a circle of radius L / tan(delta)
    xr = z[:, X] - p.cg_to_rear * np.cos(z[:, YAW])
    yr = z[:, Y] - p.cg_to_rear * np.sin(z[:, YAW])
    _, _, radius = fit_circle(xr, yr)
    assert radius == pytest.approx(p.wheelbase / math.tan(steer), rel=0.02)


@pytest.mark.parametrize("name", ["vilma", "bmw_320i"])
def test_steady_state_cornering_follows_the_understeer_gradient(name):
    p = preset(name)
    v, steer = 15.0, 0.02
    z = drive(physics_only(vehicle=p), ActuatorCommand(steer=steer, longitudinal=Longitudinal.ACCEL), 15.0,
              initial=VehicleState(vx=v, steer=steer))
    # linear single track: curvature = delta / (L + K v^2)  (Rajamani eq. 3.21)
    v_end = float(np.hypot(z[-1, VX], z[-1, 4]))
    curvature = z[-1, YAW_RATE] / v_end
    expected = steer / (p.wheelbase + p.understeer_gradient * v_end**2)
    assert curvature == pytest.approx(expected, rel=0.03)
    if p.understeer_gradient > 1e-4:
        assert curvature < steer / p.wheelbase * 0.85  # understeer: a wider circle than kinematic


def test_front_heavy_vilma_understeers_more_with_speed():
    radii = []
    for v in (8.0, 14.0, 20.0):
        z = drive(physics_only(), ActuatorCommand(steer=0.03, longitudinal=Longitudinal.ACCEL), 12.0,
                  initial=VehicleState(vx=v, steer=0.03))
        radii.append(z[-1, VX] / z[-1, YAW_RATE])
    assert radii[0] < radii[1] < radii[2]


@pytest.mark.parametrize("model", ["kinematic", "single_track"])
@pytest.mark.parametrize(
    ("initial", "cmd"),
    [
        (VehicleState(), ActuatorCommand()),  # standstill, nothing
        (VehicleState(), ActuatorCommand(brake=12_000.0)),  # standstill, full brake
        (VehicleState(), ActuatorCommand(drive=-3000.0, steer=-0.6)),  # reverse at full lock
        (VehicleState(vx=-8.0), ActuatorCommand(drive=-3000.0, steer=0.3)),  # fast reverse
        (VehicleState(vx=40.0), ActuatorCommand(drive=6000.0, steer=0.6)),  # full lock at 40 m/s
        (VehicleState(vx=40.0, steer=0.6), ActuatorCommand(brake=12_000.0, steer=-0.6)),  # hard braking
        (VehicleState(vx=0.5, vy=0.3, yaw_rate=2.0), ActuatorCommand(steer=0.6, drive=6000.0)),
    ],
)
def test_no_nan_at_the_edges(model, initial, cmd):
    z = drive(physics_only(model=model), cmd, 15.0, initial=initial)
    assert np.all(np.isfinite(z))
    assert np.all(z[:, BRAKE] >= 0.0)
    assert np.max(np.hypot(z[:, VX], z[:, 4])) < 80.0


def test_standstill_stays_exactly_put():
    z = drive(physics_only(), ActuatorCommand(), 5.0)
    assert np.all(z[:, :6] == 0.0)


def test_hard_braking_distance_is_bounded_by_friction():
    p = vilma()
    v0 = 30.0
    z = drive(physics_only(), ActuatorCommand(brake=p.max_brake_force), 8.0, initial=VehicleState(vx=v0))
    stopped = int(np.argmax(z[:, VX] < 0.05))
    assert stopped > 0
    distance = z[stopped, X]
    # no car stops shorter than friction allows; the brake split saturates the front axle first
    decel_max = p.friction * GRAVITY + p.resistance(v0) / p.mass
    front = min(p.brake_split_front * p.max_brake_force, p.friction * p.load_front)
    rear = min((1 - p.brake_split_front) * p.max_brake_force, p.friction * p.load_rear)
    decel_min = (front + rear) / p.mass
    # + the brake lag: about one time constant at the initial speed
    lag = p.actuators.brake_time_constant * v0
    assert v0**2 / (2 * decel_max) <= distance <= v0**2 / (2 * decel_min) + lag


def test_reverse_drives_backwards():
    z = drive(physics_only(), ActuatorCommand(drive=-2000.0), 5.0)
    assert z[-1, VX] < -3.0 and z[-1, X] < -5.0


def test_bmw_is_rear_wheel_drive_and_power_limited():
    p = bmw_320i()
    z = drive(physics_only(vehicle=p), ActuatorCommand(drive=p.max_drive_force), 10.0)
    v_end = z[-1, VX]
    # limited by the power once v > P / F = v_switch
    assert v_end < 7.319 + (10.0 - 7.319 / 11.5) * p.max_power / (p.mass * 7.319)


@pytest.mark.parametrize("curvature", [0.0, 0.6, -0.5])
def test_lateral_tyre_force_is_the_magic_formula(curvature):
    # Fy = -D sin(C atan(B a - E (B a - atan(B a)))), D = sqrt((mu Fz)^2 - Fx^2), B = C_alpha / (C mu Fz)
    p = plant_consts(dataclasses.replace(vilma(), tyre_curvature=curvature))
    fz, fx = p.fzf, 0.3 * p.mu * p.fzf
    b, d = p.cf / (p.shape * p.mu * fz), math.sqrt((p.mu * fz) ** 2 - fx**2)
    for alpha in (-0.4, -0.05, 0.0, 0.01, 0.2, 1.2):
        ba = b * alpha
        expected = -d * math.sin(p.shape * math.atan(ba - curvature * (ba - math.atan(ba))))
        assert lateral_tyre_force(alpha, fx, fz, p.cf, p) == pytest.approx(expected, rel=1e-12, abs=1e-9)
    # the initial slope is the cornering stiffness, shrunk by the friction ellipse: -C_alpha D / (mu Fz)
    slope = lateral_tyre_force(1e-7, fx, fz, p.cf, p) / 1e-7
    assert slope == pytest.approx(-p.cf * d / (p.mu * fz), rel=1e-6)
