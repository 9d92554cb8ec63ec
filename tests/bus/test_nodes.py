"""Simulator and driver as bus nodes drive exactly as the scenario runner's lockstep loop."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from vilma.bus import Latest, LocalBus, topic
from vilma.bus.nodes import DriverNode, SimNode
from vilma.control.driver import Driver
from vilma.core.messages import ActuatorCommand, DriverOrder, Longitudinal, SimControl
from vilma.scenario import load_scenario
from vilma.scenario.batch import BUNDLED
from vilma.scenario.runner import initial_state, run, start_task
from vilma.sim import Simulator


def _nodes(scenario):
    bus = LocalBus()
    path = scenario.reference_path()
    sim = Simulator(scenario.sim)
    start = initial_state(scenario, path)
    sim.reset(start)
    driver = Driver(sim.config.vehicle, scenario.driver, step=sim.config.step)
    sim_node = SimNode(sim, bus, start=start)
    drv = DriverNode(driver, bus, step_ns=sim.clock.step_ns)
    return bus, sim, sim_node, driver, drv, path


def test_nodes_on_the_local_bus_drive_as_the_runner():
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    bus, sim, sim_node, driver, drv, path = _nodes(scenario)
    drv.on_pose = lambda: start_task(driver, scenario, path)
    status = Latest(bus, topic("driver/status"))
    xy = []
    while not (status.value is not None and status.value.arrived and sim.state.speed < scenario.driver.rest_speed):
        sim_node.frame(sim.advance(2))
        xy.append((sim.state.x, sim.state.y))
        assert sim.clock.time_s < 60
    reference = run(scenario, compiled=False)
    assert np.array_equal(np.array(xy), reference.log.rows[:, 1:3])


def test_orders_and_reset_over_the_bus():
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    bus, sim, sim_node, _driver, _drv, path = _nodes(scenario)
    sim_node.frame(sim.advance(2))
    order = topic("driver/cmd")
    assert bus.request(order, DriverOrder(action="set_speed", speed=5.0)).ok
    for _ in range(500):
        sim_node.frame(sim.advance(2))
    assert abs(sim.state.speed - 5.0) < 0.1
    bad = bus.request(order, DriverOrder(action="set_speed"))
    assert not bad.ok and bad.error == "set_speed: give speed"
    assert bus.request(order, DriverOrder(action="fly")).error.startswith("unknown order 'fly'")
    assert bus.request(order, DriverOrder(action="follow", file="/nonexistent.txt", speed=3.0)).error == \
        "follow: /nonexistent.txt: no such file; check the path"
    assert bus.request(topic("sim/cmd"), SimControl(action="reset")).ok
    sim_node.frame(sim.advance(2))  # the reset applies at the end of this frame
    assert sim.state.speed == 0.0 and (sim.state.x, sim.state.y) == (path.xy[0, 0], path.xy[0, 1])


def test_tune_swaps_controllers_and_gains_and_refuses_what_does_not_fit():
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    bus, *_, drv, _path = _nodes(scenario)
    order = topic("driver/cmd")
    assert bus.request(order, DriverOrder(action="set_speed", speed=4.0)).ok
    reply = bus.request(order, DriverOrder(action="tune", speed_controller="vilma_pid",
                                           gains={"vilma_pid": {"kp": 150.0}, "stanley": {"gain": 2.0}}))
    assert reply.ok, reply.error
    params = drv.driver.params
    assert (params.speed_controller, params.vilma_pid.kp, params.stanley.gain) == ("vilma_pid", 150.0, 2.0)
    assert drv.driver.task.speed == 4.0  # the task goes on with the new controllers
    for gains, error in (({"nope": {}}, "tune: gains of 'nope': no such controller"),
                         ({"stanley": {"gian": 1.0}}, "tune: gains of stanley: no field 'gian'; fields are period,"),
                         ({"stanley": {"gain": math.nan}}, "tune: gains of stanley: gain must be a finite number"),
                         ({"stanley": {"window": 2.5}}, "tune: gains of stanley: window must be a finite integer"),
                         ({"stanley": {"point": 3.0}}, "tune: gains of stanley: point must be a str, got 3.0"),
                         ({"vilma_pid": {"integer_target": 1}}, "tune: gains of vilma_pid: integer_target must be")):
        reply = bus.request(order, DriverOrder(action="tune", gains=gains))
        assert not reply.ok and reply.error.startswith(error)
    assert bus.request(order, DriverOrder(action="tune", path_controller="magic")).error.startswith(
        "tune: controllers 'vilma_pid' + 'magic': use a speed controller of")
    assert drv.driver.params == params  # nothing refused was taken
    reply = bus.request(order, DriverOrder(action="follow", points=[(0.0, 0.0), (20.0, 0.0)], speeds=[2.0]))
    assert not reply.ok and "speeds must be 2 finite numbers" in reply.error


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(gains=st.dictionaries(
    st.sampled_from(["vilma_pid", "pi_ff", "stanley", "pure_pursuit", "vilma_heading", "x"]),
    st.dictionaries(st.sampled_from(["kp", "ki", "gain", "window", "point", "period", "integer_target", "zz"]),
                    st.one_of(st.floats(), st.integers(-5, 5), st.booleans(), st.text(max_size=3)), max_size=3),
    max_size=3))
def test_any_tune_order_is_answered_and_a_refused_one_changes_nothing(gains):
    bus, *_, drv, _path = _nodes(load_scenario(BUNDLED / "course_30kmh_stanley.yaml"))
    before = drv.driver.params
    reply = bus.request(topic("driver/cmd"), DriverOrder(action="tune", gains=gains))
    assert reply.ok or (reply.error.startswith("tune: ") and drv.driver.params == before)
    for name, fields in gains.items() if reply.ok else ():
        for field, value in fields.items():
            assert getattr(getattr(drv.driver.params, name), field) == value


def test_a_reset_calls_back_once_the_car_is_back_at_its_start():
    sim = Simulator()
    node = SimNode(sim, LocalBus())
    node.command(ActuatorCommand(longitudinal=Longitudinal.ACCEL, drive=2.0))
    for _ in range(100):  # 2 s at 2 m/s^2 (less the actuator's lag): a few metres
        node.frame(sim.advance(2))
    assert sim.state.x > 1.0
    seen = []
    node.reset(lambda: seen.append((sim.time_ns, sim.state)))
    assert seen == []  # a reset applies at the start of the next frame
    node.apply_pending()
    assert seen == [(0, sim.config.initial)]
    node.apply_pending()
    assert len(seen) == 1  # once
