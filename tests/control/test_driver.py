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
from vilma.trajectory.course import spline_course
from vilma.vehicle.params import vilma


@pytest.mark.parametrize("speed_controller", ["pi_ff", "vilma_pid"])
def test_stops_at_the_end_within_1_m_at_rest(speed_controller):
    path = spline_course([(0, 0), (40, 0), (60, 15)])
    run = drive_path(path, 8.0, DriverParams(speed_controller=speed_controller))
    assert run.driver.status.arrived
    assert np.hypot(*(run.xy[-1] - path.xy[-1])) < 1.0
    assert run.speed[-1] < 0.01


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
