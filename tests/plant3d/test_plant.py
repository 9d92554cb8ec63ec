"""The 3D plant against physics and against the planar single-track plant."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.conftest import fit_circle, physics_only
from vilma.core.messages import ActuatorCommand, Longitudinal
from vilma.plant3d.car_model import sprung_inertia
from vilma.plant3d.plant import MujocoPlant, ackermann
from vilma.sim import Simulator
from vilma.vehicle.params import GRAVITY, vilma
from vilma.vehicle.state import VehicleState

CAR = vilma()


def hold_speed(plant: MujocoPlant, steer: float, speed: float, seconds: float) -> np.ndarray:
    """Drive at ``speed`` with a proportional drive force; the planar states after every 10 ms."""
    out = []
    for _ in range(round(seconds / 0.01)):
        vx = plant.planar_state()[3]
        plant.step(steer, CAR.mass * 2.0 * (speed - vx) + CAR.resistance(speed), 0.0, 0.01)
        out.append(plant.planar_state())
    return np.array(out)


def test_the_car_settles_at_its_centre_of_mass_height():
    plant = MujocoPlant(CAR)
    hold_speed(plant, 0.0, 0.0, 1.0)
    z, roll, pitch = plant.attitude()
    assert z == pytest.approx(CAR.suspension.cg_height, abs=0.005)  # the springs are preloaded for the rest load
    assert abs(roll) < 1e-4 and abs(pitch) < 1e-3
    assert np.abs(plant.suspension()).max() < 0.005


def test_ackermann_angles_share_one_turning_centre():
    left, right = ackermann(0.2, CAR.wheelbase, CAR.track)
    assert left > 0.2 > right > 0  # turning left, the inner (left) wheel steers more
    centre_y = CAR.wheelbase / math.tan(0.2)
    assert CAR.wheelbase / math.tan(left) == pytest.approx(centre_y - CAR.track / 2)
    assert CAR.wheelbase / math.tan(right) == pytest.approx(centre_y + CAR.track / 2)
    assert ackermann(-0.2, CAR.wheelbase, CAR.track) == pytest.approx((-right, -left))


@pytest.mark.parametrize("steer", [0.1, -0.25])
def test_low_speed_turning_radius_is_the_bicycle_ones(steer):
    plant = MujocoPlant(CAR)
    plant.reset(VehicleState(vx=3.0, steer=steer))
    xs = hold_speed(plant, steer, 3.0, 15.0)[500:]
    radius = fit_circle(xs[:, 0], xs[:, 1])[2]
    # the rear axle turns on L / tan(delta); the centre of mass lr ahead of it
    expected = math.hypot(CAR.wheelbase / math.tan(abs(steer)), CAR.cg_to_rear)
    assert radius == pytest.approx(expected, rel=0.05)
    assert np.sign(xs[-1, 5]) == np.sign(steer)  # positive steer turns left (counter-clockwise)


def _time_to(sim: Simulator, speeds: tuple[float, ...]) -> list[float]:
    sim.command(ActuatorCommand(longitudinal=Longitudinal.POWER, drive=1000.0, velocity_limit=100.0))
    times, t = [], 0.0
    for v in speeds:
        while sim.state.speed < v:
            sim.run_for(0.05)
            t += 0.05
            assert t < 60, f"never reached {v} m/s"
        times.append(t)
    return times


def test_straight_line_acceleration_agrees_with_the_single_track_plant():
    speeds = (5.0, 10.0, 15.0)
    planar = _time_to(Simulator(physics_only()), speeds)
    plant3d = _time_to(Simulator(physics_only(model="mujoco")), speeds)
    assert plant3d == pytest.approx(planar, rel=0.15)


def test_braking_pitches_the_nose_down_by_the_load_transfer():
    plant = MujocoPlant(CAR)
    plant.reset(VehicleState(vx=15.0))
    hold_speed(plant, 0.0, 15.0, 1.0)
    brake = 6000.0
    pitches, speeds = [], []
    for _ in range(100):
        plant.step(0.0, 0.0, brake, 0.01)
        pitches.append(plant.attitude()[2])
        speeds.append(plant.planar_state()[3])
    decel = -(speeds[-1] - speeds[50]) / 0.49
    ms = sprung_inertia(CAR)[0]
    # sprung load transfer ms a h / L to the front, half on each spring; pitch = (front + rear deflection) / L
    expected = ms * decel * CAR.suspension.cg_height / (CAR.suspension.stiffness * CAR.wheelbase ** 2)
    assert np.mean(pitches[50:]) == pytest.approx(expected, rel=0.25)
    assert expected > 0  # positive pitch about the left-pointing y axis: nose down


def test_turning_rolls_the_body_outward_by_the_roll_stiffness():
    plant = MujocoPlant(CAR)
    speed, steer = 10.0, 0.06
    plant.reset(VehicleState(vx=speed, steer=steer))
    xs = hold_speed(plant, steer, speed, 6.0)
    rolls = []
    for _ in range(100):
        vx = plant.planar_state()[3]
        plant.step(steer, CAR.mass * 2.0 * (speed - vx) + CAR.resistance(speed), 0.0, 0.01)
        rolls.append(plant.attitude()[1])
    ay = xs[-1, 3] * xs[-1, 5]  # v r, steady state
    ms = sprung_inertia(CAR)[0]
    h, k, t = CAR.suspension.cg_height, CAR.suspension.stiffness, CAR.track
    expected = ms * ay * h / (k * t * t - ms * GRAVITY * h)  # roll centre on the ground: vertical struts
    assert ay > 2.0
    assert np.mean(rolls) == pytest.approx(expected, rel=0.25)
    assert np.mean(rolls) > 0  # a left turn rolls the body to the right: positive about x
