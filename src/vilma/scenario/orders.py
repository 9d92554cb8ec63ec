"""A scenario's task as the driver's order, and how the driver plans a plan task: what ``vilma up``, ``vilma
drive`` and the GUI's Plan send and set up alike."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from vilma.core.messages import DriverOrder
from vilma.scenario.spec import Scenario

if TYPE_CHECKING:  # the planner (numba, scipy.interpolate) is imported for a plan task only
    from vilma.bus.plan_node import PlanSetup


def plan_setup(scenario: Scenario | None) -> PlanSetup | None:
    """How the driver plans a plan task of ``scenario`` (None: no plan task)."""
    if scenario is None or scenario.task.kind != "plan":
        return None
    from vilma.bus.plan_node import PlanSetup  # the planner (numba): for a plan only

    return PlanSetup(params=scenario.planner, perception=scenario.perception, laser=scenario.sim.laser,
                     road=scenario.road.network if scenario.road else None)


def task_order(scenario: Scenario) -> DriverOrder:
    """The scenario's task as an order to the driver (a path with its points, and their speeds if it has them; a
    plan's goal at its route's end)."""
    t = scenario.task
    speed = math.nan if t.speed is None else t.speed
    if t.kind == "speed":
        return DriverOrder(action="set_speed", speed=speed)
    if t.kind == "go_to":
        return DriverOrder(action="go_to", x=t.go_to[0], y=t.go_to[1], speed=speed)
    path = scenario.reference_path()
    if t.kind == "plan":
        (x, y), speeds = path.xy[-1], path.speed.tolist()
        return DriverOrder(action="plan", x=float(x), y=float(y), points=path.xy.tolist(), speeds=speeds)
    return DriverOrder(action="follow", speed=speed, points=path.xy.tolist(),
                       speeds=[] if path.speed is None else path.speed.tolist())
