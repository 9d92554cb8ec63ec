import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import STEP, drive, physics_only
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.sim import Simulator
from vilma.vehicle.actuators import (
    MODE_IDS,
    CommandError,
    actuate,
    actuator_step,
    command_limits,
    targets,
    validate_command,
)
from vilma.vehicle.params import ActuatorParams, plant_consts, vilma
from vilma.vehicle.state import BRAKE, DRIVE, STEER, VX, VehicleState

P = vilma()


@pytest.mark.parametrize("field", ["steer", "drive", "brake"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_nan_and_infinity_are_rejected_naming_the_field(field, bad):
    with pytest.raises(CommandError, match=f"'{field}'"):
        validate_command(ActuatorCommand(**{field: bad}), P)


def test_velocity_limit_may_be_infinite_but_not_nan():
    validate_command(ActuatorCommand(velocity_limit=math.inf), P)
    with pytest.raises(CommandError, match="velocity_limit"):
        validate_command(ActuatorCommand(velocity_limit=math.nan), P)


def test_unknown_mode_is_rejected():
    with pytest.raises(CommandError, match="longitudinal"):
        validate_command(ActuatorCommand(longitudinal="warp"), P)


def test_out_of_range_values_are_clamped_and_reported():
    cmd, notes = validate_command(ActuatorCommand(steer=1.0, brake=-5.0), P)
    assert cmd.steer == P.max_steer and cmd.brake == 0.0
    assert len(notes) == 2 and "'steer'" in notes[0] and "clamped to 0.6" in notes[0]


def test_the_limits_a_caller_keeps_are_the_ones_checked():
    narrow = dataclasses.replace(P, max_steer=0.5 * P.max_steer)
    cmd, notes = validate_command(ActuatorCommand(steer=P.max_steer), P, command_limits(narrow).tolist())
    assert cmd.steer == narrow.max_steer and len(notes) == 1


@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(allow_nan=True, allow_infinity=True),
       st.sampled_from(list(Longitudinal)))
def test_validated_commands_are_always_finite_and_in_range(steer, drive, mode):
    try:
        cmd, _ = validate_command(ActuatorCommand(steer=steer, drive=drive, longitudinal=mode), P)
    except CommandError:
        assert not (math.isfinite(steer) and math.isfinite(drive))
        return
    assert abs(cmd.steer) <= P.max_steer and math.isfinite(cmd.drive)


NUMBER = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**6, 10**6))


@given(NUMBER, NUMBER, NUMBER, NUMBER, st.sampled_from([*Longitudinal, *(m.value for m in Longitudinal)]))
def test_a_command_is_refused_or_clamped_field_by_field_as_defined(steer, drive, brake, limit, mode):
    values = {"steer": steer, "drive": drive, "brake": brake, "velocity_limit": limit}
    bad = [k for k, v in values.items() if math.isnan(v) or (math.isinf(v) and not (k == "velocity_limit" and v > 0))]
    try:
        cmd, notes = validate_command(ActuatorCommand(longitudinal=mode, **values), P)
    except CommandError as e:
        assert bad and f"'{bad[0]}'" in str(e)  # the first bad field, in the order of the fields
        return
    assert not bad
    limits = command_limits(P)[MODE_IDS[Longitudinal(mode)]]
    clamped = {k: min(max(v, lo), hi) for (k, v), (lo, hi) in zip(values.items(), limits.tolist(), strict=True)}
    assert {k: getattr(cmd, k) for k in values} == clamped
    assert cmd.longitudinal is Longitudinal(mode)
    assert len(notes) == sum(clamped[k] != v for k, v in values.items())


def test_rejected_command_leaves_the_previous_one_in_force():
    sim = Simulator(physics_only())
    sim.command(ActuatorCommand(drive=2000.0))
    with pytest.raises(CommandError):
        sim.command(ActuatorCommand(drive=math.nan))
    sim.run_for(2.0)
    assert np.isfinite(sim._z).all()
    assert sim.state.drive_force == pytest.approx(2000.0, rel=1e-6)


def test_steering_rate_limit_and_lag():
    rate = P.actuators.steer_rate_limit
    z = drive(physics_only(), ActuatorCommand(steer=0.6), 2.0, initial=VehicleState(vx=5.0))
    t = np.arange(1, len(z) + 1) * STEP
    assert np.all(np.abs(z[:, STEER]) <= rate * t + 1e-12)
    assert z[-1, STEER] == pytest.approx(0.6, abs=1e-3)


def test_drive_force_first_order_lag():
    tau = P.actuators.drive_time_constant
    z = drive(physics_only(), ActuatorCommand(drive=1000.0), 1.0)
    i = round(tau / STEP) - 1  # state after the step ending at t = tau
    assert z[i, DRIVE] == pytest.approx(1000.0 * (1 - math.exp(-1)), rel=1e-9)


def test_dead_time_delays_the_effect():
    p = dataclasses.replace(P, actuators=ActuatorParams(dead_time=0.2))
    z = drive(physics_only(vehicle=p), ActuatorCommand(drive=1000.0), 0.5)
    delay = round(0.2 / STEP)  # the command acts from the step after the dead time
    assert np.all(z[: delay - 1, DRIVE] == 0.0)
    assert z[delay, DRIVE] > 0.0


def test_accel_mode_holds_speed_and_brakes_to_rest():
    z = drive(physics_only(), ActuatorCommand(longitudinal=Longitudinal.ACCEL), 10.0,
              initial=VehicleState(vx=15.0, drive_force=P.resistance(15.0)))
    assert z[-1, VX] == pytest.approx(15.0, abs=1e-3)  # feed-forward cancels drag and rolling
    z = drive(physics_only(), ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=-3.0), 10.0,
              initial=VehicleState(vx=15.0))
    assert abs(z[-1, VX]) < 0.01 and z[-1, BRAKE] > 0


def test_accel_mode_reaches_the_requested_acceleration():
    z = drive(physics_only(), ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=2.0), 5.0,
              initial=VehicleState(vx=5.0))
    assert (z[-1, VX] - z[-1 - round(1 / STEP), VX]) / 1.0 == pytest.approx(2.0, rel=0.01)


def test_original_velocity_amount_cuts_the_engine_and_brakes():
    cmd = ActuatorCommand(longitudinal=Longitudinal.POWER, drive=1000.0, velocity_limit=10.0)
    z = drive(physics_only(), cmd, 20.0)
    # above velocityAmount: engine force 0 and applyBraking(30) on each wheel
    assert z[-1, VX] == pytest.approx(10.0, abs=0.3)
    assert z[:, BRAKE].max() > 0.5 * 4 * 30 * P.brake_unit_force


@settings(deadline=None)  # the first example compiles
@given(st.sampled_from(sorted(MODE_IDS.values())), st.floats(-0.6, 0.6), st.floats(-5.0, 5.0), st.floats(0.0, 3000.0),
       st.floats(-5.0, 30.0))
def test_actuate_is_targets_then_actuator_step(mode, steer, drive, brake, vx):
    consts, cmd, x = plant_consts(vilma()), np.array([steer, drive, brake, 10.0]), (0.0, 0.0, 0.0, vx, 0.1, 0.02)
    u, expected = np.array([0.1, 200.0, 50.0]), np.array([0.1, 200.0, 50.0])
    actuator_step(expected, *targets(mode, cmd, x, expected, consts), consts, STEP)
    actuate(mode, cmd, x, u, np.array(consts), STEP)
    assert u.tolist() == expected.tolist()
