import math

import numpy as np
import pytest

from tests.control.conftest import drive_path
from vilma.control.driver import Driver, DriverMode, DriverParams
from vilma.control.path.stanley import StanleyParams
from vilma.control.path.vilma_heading import VilmaHeadingParams
from vilma.control.speed.pi_ff import PiFfParams
from vilma.control.speed.vilma_pid import VilmaPidParams
from vilma.core.clock import RateError
from vilma.sim import SimConfig, Simulator
from vilma.trajectory import Trajectory
from vilma.trajectory.course import spline_course
from vilma.vehicle.params import vilma
from vilma.vehicle.state import VehicleState


@pytest.mark.parametrize("speed_controller", ["pi_ff", "vilma_pid"])
def test_stops_at_the_end_within_1_m_at_rest(speed_controller):
    path = spline_course([(0, 0), (40, 0), (60, 15)])
    run = drive_path(path, 8.0, DriverParams(speed_controller=speed_controller))
    assert run.driver.status.arrived
    assert np.hypot(*(run.xy[-1] - path.xy[-1])) < 1.0
    assert run.speed[-1] < 0.01


def test_on_its_final_stop_the_driver_aims_at_the_stop_not_at_the_cruise_speed():
    """Following 60 m of straight line at 8 m/s: cruising, the target it reports is 8 m/s; once it brakes for the
    end, at most sqrt(2 a d), the speed from which its stop deceleration a ends at rest on the last point d ahead
    (never the 8 m/s it no longer aims at), and 0 once arrived."""
    path = Trajectory.from_points([(float(x), 0.0) for x in range(61)])
    sim = Simulator(SimConfig())
    sim.reset(VehicleState())
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.follow(path, 8.0)
    a, seen = d.params.stop_deceleration, []
    for _ in range(round(40 / d.period)):
        cmd = d.update(sim.advance(d.period_ticks))
        if cmd is not None:
            sim.command(cmd)
        seen.append((d.status, bool(d.state.stopping), sim.state.speed))
    cruising = [st.target_speed for st, stopping, _ in seen if not stopping]
    stopping = [(st.target_speed, st.remaining) for st, stopping, _ in seen if stopping and not st.arrived]
    assert cruising and set(cruising) == {8.0}
    assert stopping and all(v <= math.sqrt(2 * a * max(d_left, 0.0)) + 1e-9 for v, d_left in stopping)
    assert stopping[0][0] == pytest.approx(seen[len(cruising)][2], abs=0.5)  # the stop starts on the car's speed
    assert seen[-1][0].arrived and seen[-1][0].target_speed == 0.0


def test_set_speed_and_hold_current_speed():
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, DriverParams(), step=sim.config.step)
    d.set_speed(6.0)
    for _ in range(round(20 / d.period)):
        cmd = d.update(sim.advance(d.period_ticks))
        if cmd is not None:
            sim.command(cmd)
    assert sim.state.speed == pytest.approx(6.0, abs=0.05)
    d.hold_current_speed()
    assert d.task.mode == DriverMode.HOLD_SPEED and d.task.speed == pytest.approx(6.0, abs=0.05)


def test_original_hold_current_speed_truncates():
    d = Driver(vilma(), DriverParams(speed_controller="vilma_pid", gains={"vilma_pid": VilmaPidParams.original()}))
    d.state.measured = 7.9  # the speed measured last
    d.hold_current_speed()
    assert d.task.speed == 7.0


def test_manual_sends_nothing():
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, step=sim.config.step)
    assert d.update(sim.advance(d.period_ticks)) is None


def test_go_to_point_stops_on_it():
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.go_to(30.0, 10.0, 5.0)
    for _ in range(round(40 / d.period)):
        cmd = d.update(sim.advance(d.period_ticks))
        if cmd is not None:
            sim.command(cmd)
    assert d.status.arrived and math.hypot(sim.state.x - 30.0, sim.state.y - 10.0) < 1.0


def test_a_path_followed_again_keeps_its_speed_profile_made_once():
    """A sweep follows one path many times: the profile, lowered in the curve, is made once for the same path and
    speed, and anew for another speed."""
    path = spline_course([(0.0, 0.0), (30.0, 0.0), (30.0, 30.0)])
    drivers = [Driver(vilma()) for _ in range(3)]
    for d, speed in zip(drivers, (20.0, 20.0, 10.0), strict=True):
        d.follow(path, speed)
    first, again, slower = (d.task.path for d in drivers)
    assert again is first and slower is not first
    a_lat = drivers[0].params.max_lateral_accel
    assert first.speed.min() <= math.sqrt(a_lat / np.abs(path.curvature).max()) + 1e-9 < 20.0


def test_bad_orders_and_periods():
    d = Driver(vilma())
    with pytest.raises(ValueError, match="speed"):
        d.set_speed(float("nan"))
    with pytest.raises(ValueError, match="path_controller"):
        DriverParams(path_controller="magic")
    with pytest.raises(RateError, match="vilma_pid period"):
        Driver(vilma(), DriverParams(speed_controller="vilma_pid", gains={"vilma_pid": VilmaPidParams(period=0.255)}))


def test_driver_params_hold_gains_by_name_in_one_spelling():
    original = DriverParams.original()
    assert original.gains_of("vilma_pid") == VilmaPidParams.original()
    assert original.gains_of("vilma_heading") == VilmaHeadingParams(original_quirks=True)
    assert original.gains_of("stanley") == StanleyParams()  # not named: its defaults
    # defaults named or not, in any order: the same parameters
    assert DriverParams(gains={"stanley": StanleyParams(), "pi_ff": PiFfParams()}) == DriverParams()
    assert DriverParams(gains={"stanley": StanleyParams(gain=2.0), "pi_ff": PiFfParams(kp=2.0)}) == \
        DriverParams(gains=(("pi_ff", PiFfParams(kp=2.0)), ("stanley", StanleyParams(gain=2.0))))
    tuned = original.with_gains({"vilma_pid": VilmaPidParams(kp=150.0)})
    assert tuned.gains_of("vilma_pid").kp == 150.0 and tuned.gains_of("vilma_heading") == \
        original.gains_of("vilma_heading")
    with pytest.raises(ValueError, match="driver gains: controller 'magic' is unknown; use one of"):
        DriverParams(gains={"magic": StanleyParams()})


def _planned(x0: float, speed: float, seconds: float = 3.0, dt: float = 0.1):
    """A local trajectory along +x from ``x0`` [m] at a constant ``speed`` [m/s], a point every ``dt`` [s]."""
    t = np.arange(round(seconds / dt) + 1) * dt
    return Trajectory(np.column_stack([x0 + speed * t, np.zeros_like(t)]), np.full(len(t), speed))


def _drive(sim, d, seconds, replan=None):
    """Step the loop ``seconds`` [s]; ``replan(sim)`` each 0.1 s hands the driver a new local trajectory."""
    every = round(0.1 / d.period)
    for k in range(round(seconds / d.period)):
        cmd = d.update(sim.advance(d.period_ticks))
        if cmd is not None:
            sim.command(cmd)
        if replan is not None and (k + 1) % every == 0:
            replan(sim)


def test_a_replan_keeps_the_controllers_and_the_clock_running():
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.drive_plan(_planned(0.0, 5.0))
    _drive(sim, d, 1.0)
    speed_state, path_state, ticks = d.speed_ctrl.state.copy(), d.path_ctrl.state.copy(), int(d.state.ticks)
    assert speed_state.any()  # the integrator has something to lose
    d.drive_plan(_planned(sim.state.x, 5.0))
    assert d.task.mode == DriverMode.PLAN and d.state.ticks == ticks
    assert (d.speed_ctrl.state == speed_state).all() and (d.path_ctrl.state == path_state).all()


def test_a_moving_local_trajectory_replanned_on_the_go_never_stops_the_car():
    # each plan is 3 s at 6 m/s from where the car is: it ends moving, so the car drives on at its speed
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.drive_plan(_planned(0.0, 6.0))
    _drive(sim, d, 20.0, replan=lambda s: d.drive_plan(_planned(s.state.x, 6.0)))
    assert not d.state.stopping and not d.status.arrived
    assert sim.state.speed == pytest.approx(6.0, abs=0.1) and abs(sim.state.y) < 0.05


def test_a_local_trajectory_that_ends_moving_is_not_stopped_at_its_end():
    # one plan of 3 s at 6 m/s, never replanned: the driver has no more path past 18 m but no order to stop
    sim = Simulator(SimConfig())
    sim.reset(VehicleState(vx=6.0))
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.drive_plan(_planned(0.0, 6.0))
    _drive(sim, d, 4.0)
    assert not d.state.stopping and sim.state.x > 18.0 and sim.state.speed > 3.0


def test_a_local_trajectory_that_ends_at_rest_stops_the_car_on_its_end():
    # 10 m/s braking at 2 m/s^2: 25 m and 5 s to rest; the plan is that stop, with its last points repeating
    sim = Simulator(SimConfig())
    sim.reset(VehicleState(vx=10.0))
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    t = np.arange(71) * 0.1
    v = np.maximum(10.0 - 2.0 * t, 0.0)
    x = np.where(t < 5.0, 10.0 * t - t * t, 25.0)
    d.drive_plan(Trajectory(np.column_stack([x, np.zeros_like(x)]), v))
    _drive(sim, d, 10.0)
    assert d.status.arrived and sim.state.x == pytest.approx(25.0, abs=1.0) and abs(sim.state.vx) < 0.05


def test_a_plan_at_rest_holds_the_car_and_a_plan_without_speeds_is_refused():
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.drive_plan(Trajectory(np.zeros((31, 2)), np.zeros(31)))  # the planner's stop where the car stands
    _drive(sim, d, 2.0)
    assert d.status.arrived and sim.state.x == pytest.approx(0.0, abs=1e-3)
    with pytest.raises(ValueError, match="no speeds"):
        d.drive_plan(Trajectory(np.zeros((2, 2))))


def test_a_planners_stop_brakes_harder_than_a_paths_end_when_it_must():
    # 10 m/s to rest in 8 m: 6.25 m/s^2, beyond the 4 m/s^2 (twice the stop deceleration) a path's end brakes at
    sim = Simulator(SimConfig())
    sim.reset(VehicleState(vx=10.0))
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    decel = 10.0**2 / (2 * 8.0)
    assert 2 * d.params.stop_deceleration < decel <= sim.config.vehicle.actuators.max_decel
    t = np.arange(31) * 0.1
    v = np.maximum(10.0 - decel * t, 0.0)
    x = np.where(v > 0, 10.0 * t - decel * t * t / 2, 8.0)
    d.drive_plan(Trajectory(np.column_stack([x, np.zeros_like(x)]), v))
    _drive(sim, d, 4.0)
    assert d.status.arrived and sim.state.x == pytest.approx(8.0, abs=0.5)


def test_a_stop_holds_while_the_next_plans_stop_too_and_a_moving_plan_releases_it():
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.drive_plan(Trajectory(np.zeros((31, 2)), np.zeros(31)))
    _drive(sim, d, 1.0)
    assert d.status.arrived
    # a creep to a stop 0.5 m ahead (its target moved by noise): the car stays where it is
    d.drive_plan(Trajectory(np.column_stack([np.linspace(0.0, 0.5, 31), np.zeros(31)]), np.linspace(0.3, 0.0, 31)))
    _drive(sim, d, 1.0)
    assert d.status.arrived and abs(sim.state.x) < 1e-3
    d.drive_plan(_planned(0.0, 3.0))
    _drive(sim, d, 2.0)
    assert not d.status.arrived and sim.state.x > 1.0
