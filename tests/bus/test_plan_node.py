"""A ``plan`` order on the bus: the driver node perceives, plans each replan period of sim time, publishes its
tracks and plans, and drives the plan; bad plan orders are refused in one line."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from shapely import Polygon, affinity, box

from tests.bus.conftest import driver_on
from vilma.app.batch import BUNDLED
from vilma.bus import LocalBus, topic
from vilma.bus.nodes import DriverNode, SimNode
from vilma.bus.plan_node import PlanSetup
from vilma.control.driver import Driver
from vilma.core.messages import DriverOrder, LocalPlan, Reply, TrackList
from vilma.planning import PlannerParams
from vilma.scenario import load_scenario
from vilma.scenario.planned import MOT_THRESHOLD
from vilma.scenario.runner import initial_state
from vilma.sim import SimConfig, Simulator
from vilma.world.states import X, Y

ORDERS = topic("driver/cmd")
DURATION = 20.0  # [s] of sim time: the parked car's scenario passes it, or stops behind it, within 15 s
OWN_LANE = {"planner.lateral_offsets": "[0]"}  # no lane to pass in: it must stop behind the parked car
MIN_GAP = 4.0  # [m] behind it: Werling's d0 = 5 m, less 1 m of speed tracking
MIN_GAP_BESIDE = 1.3  # [m] passing it in the next lane's centre: 3.5 - 2 / 2 - 1.77 / 2 = 1.6 m, less 0.3 m


def _drive(scenario, seconds: float):
    """``scenario``'s plan task ordered over a local bus to a driver node beside a simulator node, run unpaced
    for ``seconds`` of sim time; the simulator, the node, the car's states each frame, the order's reply and what
    came on the plan's topics."""
    bus, route = LocalBus(), scenario.reference_path()
    sim = Simulator(scenario.sim)
    start = initial_state(scenario, route)
    sim.reset(start)
    sim_node = SimNode(sim, bus, start=start)
    node = DriverNode(Driver(sim.config.vehicle, scenario.driver, step=sim.config.step), bus,
                      step_ns=sim.clock.step_ns,
                      planning=PlanSetup(params=scenario.planner, perception=scenario.perception,
                                         laser=scenario.sim.laser))
    (gx, gy), got = route.xy[-1], {"tracks": [], "plans": [], "replies": []}
    order = DriverOrder(action="plan", x=float(gx), y=float(gy), points=route.xy.tolist(),
                        speeds=route.speed.tolist())
    node.on_pose = lambda: got["replies"].append(node.order(order))
    bus.subscribe(topic("perception/objects"), got["tracks"].append)
    bus.subscribe(topic("planning/plan"), got["plans"].append)
    states = []
    while sim.clock.time_s < seconds:
        sim_node.frame(sim.advance(2))
        states.append((sim.state.x, sim.state.y, sim.state.yaw))
    return sim, node, np.array(states), got


def _gaps(states: np.ndarray, sim) -> np.ndarray:
    """The distance [m] between the car's box and the parked car's at each of ``states`` (x, y, yaw)."""
    car, traffic = sim.config.vehicle, sim.config.traffic
    (where,) = traffic.at(0.0)[0]
    parked = affinity.translate(affinity.rotate(Polygon(traffic.outline[0]), where[2], use_radians=True),
                                where[0], where[1])
    body = box(car.body_offset - car.length / 2, -car.width / 2, car.body_offset + car.length / 2, car.width / 2)
    return np.array([parked.distance(affinity.translate(affinity.rotate(body, yaw, (0, 0), use_radians=True), x, y))
                     for x, y, yaw in states])


@pytest.mark.slow
@pytest.mark.parametrize(("perception", "overrides"), [("truth", None), ("laser", OWN_LANE)])
def test_a_planned_car_on_the_bus_passes_or_stops_behind_the_parked_car(perception, overrides):
    """As bundled (truth, two lanes to plan in) the car passes the parked car in the next lane and gets back in
    its own; with its lane only (and the laser) it stops behind it."""
    extra = {"perception": "laser", "laser": "true"} if perception == "laser" else {}
    scenario = load_scenario(BUNDLED / "planned_parked_car.yaml", {**extra, **(overrides or {})})
    sim, node, states, got = _drive(scenario, DURATION)
    assert got["replies"] == [Reply(ok=True)]
    traffic, rest = sim.config.traffic, scenario.driver.rest_speed
    (parked,), (where,) = traffic.ids, traffic.at(0.0)[0]  # the one obstacle, as the scenario's file has it
    plans, tracks = got["plans"], got["tracks"]
    # a cycle each replan period of sim time, from the order's first frame with a pose to the end
    period_ns = round(scenario.planner.replan_period * 1e9)
    assert all(isinstance(p, LocalPlan) for p in plans) and len(plans) >= 2
    assert all(p.planning_ms > 0 for p in plans)  # each cycle's own time (NaN if unmeasured)
    assert np.all(np.diff([p.stamp_ns for p in plans]) == period_ns)
    assert plans[-1].stamp_ns > round(DURATION * 1e9) - 2 * period_ns
    assert all(isinstance(t, TrackList) and t.source == perception for t in tracks)
    # the objects sensor's noisy truth is within a metre; a laser box spans the faces it sees (MOT's threshold)
    near = 1.0 if perception == "truth" else MOT_THRESHOLD
    seen = [o for t in tracks for o in t.objects if math.hypot(o.x - where[X], o.y - where[Y]) <= near]
    assert seen and (perception == "laser" or {o.id for o in seen} == {parked})
    gaps, z = _gaps(states, sim), sim.state
    if overrides is None:  # passed in the lane to its left (3.5 m over), and back in its own past it
        beside = np.abs(states[:, 0] - where[X]) < traffic.outline[0, :, 0].max()
        assert beside.any() and states[beside, 1].min() > 3.5 - 0.5
        assert gaps.min() >= MIN_GAP_BESIDE and z.x > where[X] and abs(z.y) < 0.3
    else:  # behind it, at rest, the last plans following it to a stop (or the planner's stop: a fallback)
        assert abs(z.speed) < rest and node.driver.status.mode == "plan" and gaps[-1] >= MIN_GAP
        near_end = plans[-round(5.0 / scenario.planner.replan_period):]
        assert {p.mode for p in near_end} <= {"follow", "stop", "fallback"} and "follow" in {p.mode for p in near_end}
        assert all(p.speed[-1] < rest for p in near_end if p.mode == "fallback")


def _with_pose():
    """A driver node with a pose (the default car at the origin, heading +x) on a local bus."""
    bus, sim = LocalBus(), Simulator()
    sim_node = SimNode(sim, bus)
    node = DriverNode(Driver(sim.config.vehicle, step=sim.config.step), bus, step_ns=sim.clock.step_ns)
    sim_node.frame(sim.advance(2))
    assert node.driver.estimator.estimate is not None
    return bus, sim, sim_node, node


BEHIND = "is behind the car"
TOP = SimConfig().vehicle.top_speed
"""The default car's top speed [m/s]."""


@pytest.mark.parametrize(("order", "error"), [
    (DriverOrder(action="plan", x=math.nan, y=0.0, speed=5.0),
     "plan: goal x=nan y=0.0 is not a point; give finite x and y [m]"),
    (DriverOrder(action="plan", x=math.inf, y=0.0, speed=5.0),
     "plan: goal x=inf y=0.0 is not a point; give finite x and y [m]"),
    (DriverOrder(action="plan", x=-20.0, y=0.0, speed=5.0),
     "plan: goal [-20.0, 0.0] is behind the car; give a goal ahead of it, or the route"),
    (DriverOrder(action="plan", x=-20.0, y=0.0, points=[(-50.0, 0.0), (50.0, 0.0)], speeds=[5.0, 5.0]),
     "plan: goal [-20.0, 0.0] is behind the car on the route; give a goal ahead of it"),
    (DriverOrder(action="plan", x=-60.0, y=0.0, points=[(-50.0, 0.0), (50.0, 0.0)], speed=5.0),
     "plan: goal [-60.0, 0.0] is behind the car on the route; give a goal ahead of it"),
    (DriverOrder(action="plan", x=30.0, y=0.0),
     "plan: a straight route to the goal needs a speed; give speed [m/s]"),
    (DriverOrder(action="plan", x=30.0, y=0.0, speed=-1.0),
     f"plan: speed -1.0 m/s: give a speed above 0, up to the car's top speed, {TOP:.3g} m/s"),
    (DriverOrder(action="plan", x=30.0, y=0.0, speed=TOP * 1.01),
     f"plan: speed {TOP * 1.01!r} m/s: give a speed above 0, up to the car's top speed, {TOP:.3g} m/s"),
    (DriverOrder(action="plan", x=30.0, y=0.0, points=[(0.0, 0.0)], speed=5.0),
     "plan: route points must be 2 or more distinct finite [x, y] pairs [m]"),
    (DriverOrder(action="plan", x=30.0, y=0.0, points=[(0.0, 0.0), (math.nan, 0.0)], speed=5.0),
     "plan: route points must be 2 or more distinct finite [x, y] pairs [m]"),
    (DriverOrder(action="plan", x=30.0, y=0.0, points=[(1.0, 0.0), (1.0, 0.0)], speed=5.0),
     "plan: route points must be 2 or more distinct finite [x, y] pairs [m]"),
    (DriverOrder(action="plan", x=30.0, y=0.0, points=[(0.0, 0.0), (50.0, 0.0)], speeds=[5.0]),
     "plan: route of 2 points with 1 speeds; give a speed for each point, or speed [m/s]"),
    (DriverOrder(action="plan", x=30.0, y=0.0, points=[(0.0, 0.0), (50.0, 0.0)], speeds=[5.0, -5.0]),
     f"plan: route speeds must be from 0 to the car's top speed, {TOP:.3g} m/s"),
    (DriverOrder(action="plan", x=2e5, y=0.0, speed=5.0),
     "plan: goal [200000.0, 0.0] is over 100000 m from the car; give a nearer goal"),
    (DriverOrder(action="plan", x=30.0, y=0.0, points=[(0.0, 0.0), (50.0, 0.0), (0.0, 2e5)], speed=5.0),
     "plan: route points over 100000 m from the car; send the route near the car"),
    (DriverOrder(action="plan", x=30.0, y=0.0, points=[(0.0, 0.0), (1e-8, 0.0), (5e4, 0.0)], speed=5.0),
     "plan: route points spaced from 1e-08 m to 5e+04 m apart; resample the route evenly (vilma trajectory "
     "resample)"),
    (DriverOrder(action="plan", x=30.0, y=0.0, file="route.csv", speed=5.0),
     "plan: a plan order names no file; send the route's points"),
])
def test_a_bad_plan_order_is_refused_in_one_line_and_the_node_keeps_serving(order, error):
    bus, sim, sim_node, node = _with_pose()
    assert bus.request(ORDERS, order) == Reply(ok=False, error=error)
    assert node.driver.status.mode == "manual"
    assert bus.request(ORDERS, DriverOrder(action="plan", x=30.0, y=0.0, speed=5.0)).ok  # still serving
    plans = []
    bus.subscribe(topic("planning/plan"), plans.append)
    for _ in range(10):
        sim_node.frame(sim.advance(2))
    assert plans and node.driver.status.mode == "plan"


def test_a_plan_order_before_the_first_pose_is_refused():
    bus = LocalBus()
    driver_on(bus)
    reply = bus.request(ORDERS, DriverOrder(action="plan", x=30.0, y=0.0, speed=5.0))
    assert reply == Reply(ok=False, error="plan: no pose of the car yet; send the order once the simulator runs")


def test_a_plan_order_is_published_with_its_route_and_another_order_ends_it():
    bus, sim, sim_node, node = _with_pose()
    taken, plans = [], []
    bus.subscribe(ORDERS, taken.append)
    bus.subscribe(topic("planning/plan"), plans.append)
    assert bus.request(ORDERS, DriverOrder(action="plan", x=30.0, y=0.0, speed=5.0)).ok
    # the straight route from the car to the goal, at the order's speed (a straight line: no curve lowers it)
    assert np.array_equal(taken[-1].points, [(0.0, 0.0), (30.0, 0.0)]) and taken[-1].speeds == [5.0, 5.0]
    sim_node.frame(sim.advance(2))
    assert len(plans) == 1 and node.driver.status.mode == "plan"
    assert bus.request(ORDERS, DriverOrder(action="set_speed", speed=2.0)).ok
    for _ in range(20):
        sim_node.frame(sim.advance(2))
    assert len(plans) == 1 and node.driver.status.mode == "set_speed"


@pytest.fixture(scope="module")
def posed():
    return _with_pose()


_floats = st.one_of(st.floats(), st.floats(-100, 100))
_orders = st.builds(
    DriverOrder, action=st.just("plan"), speed=_floats, x=_floats, y=_floats,
    points=st.lists(st.tuples(_floats, _floats), max_size=5), speeds=st.lists(_floats, max_size=5),
    file=st.sampled_from(["", "route.csv", "/etc/passwd"]))


@settings(max_examples=80, deadline=None)
@given(order=_orders)
def test_any_plan_order_gets_a_one_line_answer_and_the_node_keeps_serving(posed, order):
    bus, _sim, _sim_node, _node = posed
    reply = bus.request(ORDERS, order)
    assert isinstance(reply, Reply) and (reply.ok or (reply.error.startswith("plan: ") and "\n" not in reply.error))
    assert not (order.file and reply.ok)
    assert bus.request(ORDERS, DriverOrder(action="manual")).ok


def test_a_tune_goes_on_with_the_plan_under_way_on_the_new_driver():
    bus, sim, sim_node, node = _with_pose()
    plans = []
    bus.subscribe(topic("planning/plan"), plans.append)
    assert bus.request(ORDERS, DriverOrder(action="plan", x=60.0, y=0.0, speed=5.0)).ok
    for _ in range(25):
        sim_node.frame(sim.advance(2))
    old, speed, before = node.driver, sim.state.speed, len(plans)
    assert bus.request(ORDERS, DriverOrder(action="tune", path_controller="pure_pursuit")).ok
    assert node.driver is not old and node.driver.status.mode == "plan"  # the plan driven goes on at once
    for _ in range(50):  # 1 s: the plans go on to the new driver, which speeds the car up to the plans' 5 m/s
        sim_node.frame(sim.advance(2))
    assert len(plans) > before and node.driver.status.mode == "plan" and speed < sim.state.speed < 5.0 + 0.1
    assert node.driver.task.path is not None and node.driver.params.path_controller == "pure_pursuit"


@pytest.mark.parametrize(("setup", "error"), [
    (PlanSetup(perception="laser"),
     "plan: laser perception needs the laser sensor: start the driver with the scenario's laser"),
    (PlanSetup(params=PlannerParams(horizon=3.0, dt=0.03, replan_period=0.03)),  # the driver's period: 0.02 s
     "plan: planner replan_period 0.03 s is not a whole number of driver periods of 0.02 s; make it one"),
])
def test_a_plan_the_driver_cannot_run_is_refused_in_one_line(setup, error):
    bus, _sim, _sim_node, node = _with_pose()
    node.planning = setup
    assert bus.request(ORDERS, DriverOrder(action="plan", x=30.0, y=0.0, speed=5.0)) == Reply(ok=False, error=error)
    assert node.driver.status.mode == "manual"
