"""Simulator and driver as bus nodes drive exactly as the scenario runner's lockstep loop."""

from __future__ import annotations

import logging
import math
import time
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.bus.conftest import SECRET, data_folder, driver_on, free_endpoint
from vilma.app.batch import BUNDLED
from vilma.bus import Latest, LocalBus, topic
from vilma.bus.nodes import DriverNode, SimNode
from vilma.bus.zenoh_bus import ZenohBus, ZenohConfig
from vilma.control.driver import Driver
from vilma.core.messages import (
    MAX_ORDER_POINTS,
    ActuatorCommand,
    DriverOrder,
    Longitudinal,
    Reply,
    SimControl,
    SimStatus,
)
from vilma.scenario import load_scenario
from vilma.scenario.runner import initial_state, run, start_task
from vilma.sim import Simulator
from vilma.trajectory.io import MAX_FILE_BYTES

ORDERS = topic("driver/cmd")
FILES_OFF = ("follow: file orders are off: start the driver with --data-dir DIR to follow files in DIR, or send "
             "the points")


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
    assert bus.request(topic("sim/cmd"), SimControl(action="reset")).ok
    sim_node.frame(sim.advance(2))  # the reset applies at the end of this frame
    assert sim.state.speed == 0.0 and (sim.state.x, sim.state.y) == (path.xy[0, 0], path.xy[0, 1])


def test_a_foreign_status_far_ahead_costs_the_driver_one_period(caplog):
    """A peer's ``sim/status`` stamped 10^8 driver periods ahead would have the driver run every one of them;
    it takes up from that stamp instead, with a warning."""
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    bus, sim, sim_node, driver, drv, _path = _nodes(scenario)
    sim_node.frame(sim.advance(2))
    ahead = sim.time_ns + 10**8 * drv.period_ns
    ticks = driver.state.ticks
    with caplog.at_level(logging.WARNING, logger="vilma.bus.nodes"):
        bus.publish(topic("sim/status"), SimStatus(stamp_ns=ahead))
    assert driver.state.ticks == ticks + driver.period_ticks  # one period, not 10^8
    assert "a simulator frame 2e+06 s ahead of the last; the driver takes up from it" in caplog.text
    bus.publish(topic("sim/status"), SimStatus(stamp_ns=ahead + drv.period_ns))  # and goes on from there
    assert driver.state.ticks == ticks + 2 * driver.period_ticks


def test_a_peer_flooding_bad_commands_gets_one_line_a_second(caplog):
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    bus, sim, sim_node, _driver, _drv, _path = _nodes(scenario)
    t0 = time.monotonic()
    with caplog.at_level(logging.WARNING, logger="vilma.bus.nodes"):
        for _ in range(100):
            bus.publish(topic("cmd"), ActuatorCommand(drive=math.nan))
        sim_node.frame(sim.advance(2))
    lines = [r.getMessage() for r in caplog.records]
    assert 1 <= len(lines) <= 1 + (time.monotonic() - t0)  # one line a second at most
    assert lines[0] == "refused a command: command field 'drive' is nan: must be a finite number"


def test_tune_swaps_controllers_and_gains_and_refuses_what_does_not_fit():
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    bus, *_, drv, _path = _nodes(scenario)
    order = topic("driver/cmd")
    assert bus.request(order, DriverOrder(action="set_speed", speed=4.0)).ok
    reply = bus.request(order, DriverOrder(action="tune", speed_controller="vilma_pid",
                                           gains={"vilma_pid": {"kp": 150.0}, "stanley": {"gain": 2.0}}))
    assert reply.ok, reply.error
    params = drv.driver.params
    assert params.speed_controller == "vilma_pid"
    assert (params.gains_of("vilma_pid").kp, params.gains_of("stanley").gain) == (150.0, 2.0)
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
            assert getattr(drv.driver.params.gains_of(name), field) == value


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


def _request_peak(bus, order: DriverOrder) -> tuple[Reply, int]:
    """The reply to ``order`` and the most memory Python held while it was answered [bytes]."""
    tracemalloc.start()
    try:
        return bus.request(ORDERS, order), tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_file_orders_are_off_without_a_data_folder():
    bus = LocalBus()
    drv = driver_on(bus)
    for name in ("/etc/passwd", "/dev/zero", "track.csv"):
        reply, peak = _request_peak(bus, DriverOrder(action="follow", file=name, speed=3.0))
        assert reply.error == FILES_OFF and peak < MAX_FILE_BYTES  # refused unread
    assert drv.driver.task.path is None


def _outside(name: str) -> str:
    return (f"follow: file {name!r} is not in the driver's data folder; name a file in it (no leading '/', no '..', "
            "no link out of it)")


@pytest.mark.parametrize(("name", "error"), [
    *((name, _outside(name)) for name in ("/etc/passwd", "/dev/zero", "../secret.txt", "secret.txt", "zero",
                                          "sub/../good.csv", "good.csv\0")),
    ("pipe", "follow: file 'pipe': not a regular file (a folder, device or pipe); give a trajectory file"),
    ("sub", "follow: file 'sub': not a regular file (a folder, device or pipe); give a trajectory file"),
    ("missing.csv", "follow: file 'missing.csv': no such file; check the path"),
    ("loop", "follow: file 'loop': cannot read it (Too many levels of symbolic links); check permissions"),
    ("big.txt", f"follow: file 'big.txt': {MAX_FILE_BYTES + 1} bytes, over the {MAX_FILE_BYTES // 2**20} MiB a "
                "trajectory file may hold; keep fewer points (every n-th line)"),
    ("bad.txt", "follow: file 'bad.txt' line 2: not a trajectory file (the driver's log says why)"),
])
def test_file_orders_take_only_regular_files_of_the_data_folder_and_never_quote_them(tmp_path, caplog, name, error):
    bus = LocalBus()
    drv = driver_on(bus, data_folder(tmp_path))
    with caplog.at_level(logging.WARNING):
        reply, peak = _request_peak(bus, DriverOrder(action="follow", file=name, speed=3.0))
    assert reply.error == error and peak < MAX_FILE_BYTES  # (so the large file was not read either)
    assert (SECRET in caplog.text) == (name == "bad.txt")  # why a file in the folder does not parse: the log only
    assert drv.driver.task.path is None and bus.request(ORDERS, DriverOrder(action="set_speed", speed=2.0)).ok


@pytest.mark.parametrize("name", ["good.csv", "same.csv", "./good.csv"])
def test_a_trajectory_file_of_the_data_folder_is_followed(tmp_path, name):
    bus = LocalBus()
    drv = driver_on(bus, data_folder(tmp_path))
    assert bus.request(ORDERS, DriverOrder(action="follow", file=name)).ok
    path = drv.driver.task.path
    assert np.array_equal(path.xy, [(0, 0), (30, 0)]) and np.array_equal(path.speed, [2, 2])


def test_an_order_of_too_many_points_is_refused_and_the_node_keeps_serving():
    bus = LocalBus()
    drv = driver_on(bus)
    straight = [(float(i), 0.0) for i in range(MAX_ORDER_POINTS + 1)]
    reply = bus.request(ORDERS, DriverOrder(action="follow", points=straight, speed=3.0))
    assert reply.error == (f"follow: {MAX_ORDER_POINTS + 1} points, over the {MAX_ORDER_POINTS} an order may carry; "
                           "resample the path coarser (vilma trajectory resample)")
    assert drv.driver.task.path is None
    assert bus.request(ORDERS, DriverOrder(action="follow", points=straight[:-1], speed=3.0)).ok
    assert len(drv.driver.task.path) == MAX_ORDER_POINTS


@pytest.fixture(scope="module", params=["local", "zenoh"])
def orders_bus(request, tmp_path_factory):
    """The bus to send orders on to a driver node with a data folder: the same local bus, or a Zenoh session
    connected to the node's."""
    data = data_folder(tmp_path_factory.mktemp("orders"))
    if request.param == "local":
        bus = LocalBus()
        node = driver_on(bus, data)
        yield bus
    else:
        endpoint = free_endpoint()
        server, bus = ZenohBus(ZenohConfig(listen=(endpoint,))), ZenohBus(ZenohConfig(connect=(endpoint,)))
        node = driver_on(server, data)
        deadline = time.monotonic() + 20
        while not bus.request(ORDERS, DriverOrder(action="manual"), timeout=0.5).ok:  # until the peers meet
            assert time.monotonic() < deadline, "the Zenoh sessions never met"
        yield bus
        server.close()
    node.close()
    bus.close()


_words = st.one_of(st.sampled_from(["manual", "set_speed", "hold_speed", "go_to", "follow", "plan", "tune", "stanley",
                                    "vilma_pid", "gain", "kp", "point"]), st.text(max_size=70))
_many = st.integers(0, 2 * MAX_ORDER_POINTS)  # up to 5.6 MB of points and speeds on the wire
_orders = st.builds(
    DriverOrder, action=_words, speed=st.floats(), x=st.floats(), y=st.floats(),
    points=st.one_of(st.lists(st.tuples(st.floats(), st.floats()), max_size=6),
                     _many.map(lambda n: [(float(i), 0.0) for i in range(n)])),
    speeds=st.one_of(st.lists(st.floats(), max_size=6), _many.map(lambda n: [1.0] * n)),
    file=st.one_of(st.sampled_from(["", "good.csv", "bad.txt", "big.txt", "pipe", "sub", "zero", "loop", "secret.txt",
                                    "../secret.txt", "/dev/zero", "/etc/passwd"]),
                   st.text(max_size=40), st.integers(0, 5000).map(lambda n: "a" * n)),
    speed_controller=_words, path_controller=_words,
    gains=st.one_of(st.dictionaries(_words, st.dictionaries(_words, st.one_of(
        st.floats(), st.integers(-2**63, 2**64 - 1), st.booleans(), st.text(max_size=70)), max_size=4), max_size=4),
        st.integers(0, 40).map(lambda n: {f"c{i}": {} for i in range(n)})))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(order=_orders)
def test_any_order_gets_a_one_line_answer_and_the_node_keeps_serving(orders_bus, order):
    reply = orders_bus.request(ORDERS, order, timeout=30)
    assert isinstance(reply, Reply) and (reply.ok or reply.error) and "\n" not in reply.error
    assert SECRET not in reply.error and "nobody answered" not in reply.error
    assert orders_bus.request(ORDERS, DriverOrder(action="set_speed", speed=1.0), timeout=30).ok


@pytest.fixture(scope="module")
def local_driver():
    """A driver node (no pose: the car at the origin) on a local bus, and the bus."""
    bus = LocalBus()
    node = driver_on(bus)
    yield bus, node
    node.close()
    bus.close()


@given(speed=st.floats())
def test_an_orders_speed_is_taken_above_0_up_to_the_cars_top_speed_and_0_to_set_a_stop(local_driver, speed):
    bus, node = local_driver
    top = node.driver.vehicle.top_speed
    for order in (DriverOrder(action="set_speed", speed=speed), DriverOrder(action="go_to", x=10.0, y=0.0, speed=speed),
                  DriverOrder(action="follow", points=[(0.0, 0.0), (10.0, 0.0)], speed=speed)):
        low = speed >= 0 if order.action == "set_speed" else speed > 0  # (NaN: no speed, which these orders need)
        assert bus.request(ORDERS, order).ok == (low and speed <= top)


@pytest.mark.parametrize(("order", "error"), [
    (DriverOrder(action="set_speed", speed=-50.0),
     "set_speed: speed -50.0 m/s: give 0 (a stop) or more, up to the car's top speed, {top} m/s"),
    (DriverOrder(action="set_speed", speed=1e300),
     "set_speed: speed 1e+300 m/s: give 0 (a stop) or more, up to the car's top speed, {top} m/s"),
    (DriverOrder(action="go_to", x=10.0, y=0.0, speed=-5.0),
     "go_to: speed -5.0 m/s: give a speed above 0, up to the car's top speed, {top} m/s"),
    (DriverOrder(action="go_to", x=1e300, y=1e300, speed=5.0),
     "go_to: goal [1e+300, 1e+300] is over 100000 m from the car; give a nearer goal"),
    (DriverOrder(action="go_to", x=math.nan, y=0.0, speed=5.0),
     "go_to: goal x=nan y=0.0 is not a point; give finite x and y [m]"),
    (DriverOrder(action="follow", points=[(1.0, 1.0), (1.0, 1.0)], speed=3.0),
     "follow: path points must be 2 or more distinct finite [x, y] pairs [m]"),
    (DriverOrder(action="follow", points=[(0.0, 0.0), (10.0, 0.0)], speeds=[-5.0, -5.0]),
     "follow: path speeds must be from 0 to the car's top speed, {top} m/s"),
    (DriverOrder(action="follow", points=[(0.0, 0.0), (10.0, 0.0)], speeds=[5.0, 1e300]),
     "follow: path speeds must be from 0 to the car's top speed, {top} m/s"),
    (DriverOrder(action="follow", points=[(0.0, 0.0), (2e5, 0.0)], speed=3.0),
     "follow: path points over 100000 m from the car; send the path near the car"),
])
def test_a_bad_order_is_refused_in_one_line_as_a_plan_order_is_and_the_task_goes_on(local_driver, order, error):
    bus, node = local_driver
    assert bus.request(ORDERS, DriverOrder(action="set_speed", speed=2.0)).ok
    assert bus.request(ORDERS, order) == Reply(ok=False, error=error.format(top=f"{node.driver.vehicle.top_speed:.3g}"))
    assert node.driver.status.mode == "set_speed" and node.driver.task.speed == 2.0


def test_nodes_in_a_with_block_leave_the_bus_even_when_the_block_raises():
    bus = LocalBus()
    with pytest.raises(RuntimeError, match="boom"), SimNode(Simulator(), bus) as sim_node, driver_on(bus) as drv:
        assert isinstance(sim_node, SimNode) and isinstance(drv, DriverNode)
        assert bus.request(topic("sim/cmd"), SimControl(action="status")).ok
        raise RuntimeError("boom")
    for key in (topic("sim/cmd"), topic("driver/cmd")):
        assert bus.request(key, SimControl(action="status")).error == f"nobody answers on {key}"
