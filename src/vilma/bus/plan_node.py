"""A ``plan`` order on the bus: the driver node's local planning (:class:`~vilma.control.local_planning.LocalPlanning`)
on the scans of topic ``objects`` (``truth`` perception) or ``laser``, which publishes the tracks on
``perception/objects`` after each scan and each planning cycle on ``planning/plan``.

The order gives the goal (``x``, ``y`` [m]) and the route: its ``points`` with their ``speeds`` (or ``speed`` [m/s]
for all, lowered in curves), or none for a straight route from the car to the goal at ``speed``. The route is cut
where the goal projects on it. A plan order never names a file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from vilma.bus.base import Bus
from vilma.bus.orders import check_goal, check_points, order_speed
from vilma.bus.topics import topic
from vilma.control.driver import Driver
from vilma.control.local_planning import LocalPlanning, default_planner, road_bounds
from vilma.core.messages import MAX_ORDER_POINTS, MAX_TRACKS, DriverOrder, Message, PoseEstimate
from vilma.planning import NO_ROAD, Plan, PlannerParams, local_plan, track_list
from vilma.plant3d.laser import LaserParams
from vilma.trajectory import Trajectory, speed_profile

if TYPE_CHECKING:  # the roads extra
    from vilma.world.commonroad import RoadNetwork

MAX_SPACING_RATIO = 1e6
"""Most a route's longest segment may be of its shortest (the Frenet frame's spline is ill-conditioned beyond)."""


@dataclass(frozen=True, slots=True, kw_only=True)
class PlanSetup:
    """How a driver node plans a ``plan`` order: the planner (None: :func:`default_planner` for the driver's car),
    the perception (``truth`` or ``laser``), the laser a ``laser`` perception reads, and the road network whose
    edges the plans keep within (:func:`~vilma.control.local_planning.road_bounds`; None: unbounded) and whose lanes
    the tracks are predicted along."""

    params: PlannerParams | None = None
    perception: str = "truth"
    laser: LaserParams | None = None
    road: RoadNetwork | None = None


class LivePlan:
    """A plan order under way: its :class:`LocalPlanning`, which publishes what it perceives and plans on ``bus``
    under ``car``."""

    def __init__(self, bus: Bus, car: str, local: LocalPlanning) -> None:
        self.bus, self.local = bus, local
        self._tracks, self._plans = topic("perception/objects", car), topic("planning/plan", car)

    def perceive(self, scans: list[Message], pose: PoseEstimate | None) -> None:
        """Take the scans of a frame, seen from the estimated ``pose``; the tracks go out after each."""
        for msg in scans:
            if self.local.take(msg, pose):
                self.bus.publish(self._tracks, track_list(msg.stamp_ns, self.local.kind,
                                                          self.local.tracks[:MAX_TRACKS]))

    def cycle(self, t_ns: int) -> None:
        """Plan at sim time ``t_ns`` [ns] and publish the cycle (nothing without a pose)."""
        self._publish(t_ns, self.local.cycle(t_ns * 1e-9))

    def period_done(self, t_ns: int) -> None:
        """A driver period ended at sim time ``t_ns`` [ns]: plan if a replan period is over, and publish it."""
        self._publish(t_ns, self.local.period_done(t_ns * 1e-9))

    def _publish(self, t_ns: int, result: Plan | None) -> None:
        if result is not None:
            self.bus.publish(self._plans, local_plan(t_ns, result, self.local.predicted_tracks[:MAX_TRACKS],
                                                     self.local.predicted[:MAX_TRACKS],
                                                     planning_ms=self.local.last_ms))


def start_plan(order: DriverOrder, driver: Driver, setup: PlanSetup, bus: Bus, car: str) -> LivePlan:
    """The planning of a ``plan`` order for ``driver`` (its route is :attr:`LivePlan.local`'s ``path``).

    Raises:
        ValueError: a goal not finite or behind the car, no pose yet, a malformed route; one line each.
    """
    if order.file:
        raise ValueError("a plan order names no file; send the route's points")
    goal = (order.x, order.y)
    if not all(math.isfinite(v) for v in goal):
        raise ValueError(f"goal x={order.x!r} y={order.y!r} is not a point; give finite x and y [m]")
    est = driver.estimator.estimate
    if est is None:
        raise ValueError("no pose of the car yet; send the order once the simulator runs")
    check_goal(order.x, order.y, (est.x, est.y))
    route = _route(order, driver, est)
    try:
        route = route.cut_at(goal)
    except ValueError:
        raise ValueError(f"goal {list(goal)} is behind the car on the route; give a goal ahead of it") from None
    if route.project(est.x, est.y).s >= route.length:
        raise ValueError(f"goal {list(goal)} is behind the car on the route; give a goal ahead of it")
    params = setup.params or default_planner(driver.vehicle)
    road = NO_ROAD if setup.road is None else road_bounds(setup.road, route)
    lanes = None if setup.road is None else setup.road.lanes
    return LivePlan(bus, car, LocalPlanning(params, setup.perception, setup.laser, route, driver, road, lanes=lanes))


def _route(order: DriverOrder, driver: Driver, est: PoseEstimate) -> Trajectory:
    """The order's route with speeds: its points, or a straight line from the car to the goal."""
    top = driver.vehicle.top_speed
    speed = None if math.isnan(order.speed) else order_speed(order.speed, top)
    if not order.points:
        if speed is None:
            raise ValueError("a straight route to the goal needs a speed; give speed [m/s]")
        if (order.x - est.x) * math.cos(est.yaw) + (order.y - est.y) * math.sin(est.yaw) <= 0:
            raise ValueError(f"goal {[order.x, order.y]} is behind the car; give a goal ahead of it, or the route")
        return Trajectory([(est.x, est.y), (order.x, order.y)], [speed, speed])
    if len(order.points) > MAX_ORDER_POINTS:  # (a decoder refuses them first; this is for in-process senders)
        raise ValueError(f"{len(order.points)} route points, over the {MAX_ORDER_POINTS} an order may carry; "
                         "resample the route coarser (vilma trajectory resample)")
    if speed is None and len(order.speeds) != len(order.points):
        raise ValueError(f"route of {len(order.points)} points with {len(order.speeds)} speeds; give a speed for "
                         "each point, or speed [m/s]")
    xy = np.asarray(order.points, dtype=np.float64).reshape(-1, 2)
    speeds = np.asarray(order.speeds, dtype=np.float64) if speed is None else None
    check_points(xy, speeds, (est.x, est.y), top, "route")
    segments = np.hypot(*np.diff(xy, axis=0).T)
    segments = segments[segments > 1e-9]  # (repeated points: the Frenet frame drops them)
    if segments.max() > MAX_SPACING_RATIO * segments.min():
        raise ValueError(f"route points spaced from {segments.min():.3g} m to {segments.max():.3g} m apart; resample "
                         "the route evenly (vilma trajectory resample)")
    if speeds is not None:
        return Trajectory(xy, speeds)
    p = driver.params
    return speed_profile(Trajectory(xy), speed, p.max_lateral_accel, p.stop_deceleration)
