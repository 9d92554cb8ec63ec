"""The anchor of ``benchmarks/planner_vs_reactive.py``: CommonRoad's own ``commonroad-reactive-planner`` (Werling's
sampling planner in a Frenet frame) in closed loop on one CommonRoad file, the way its example ``run_planner.py``
drives it.

Its route planner's shortest reference path, a plan every 0.3 s over a 2 s horizon (its example configurations:
``dt`` the scenario's, ``replanning_frequency`` 3, ``time_steps_computation`` 20), one process, and the ego
following each plan exactly (its perfect tracking) until its own goal check passes, a plan fails or raises, or the
time limit (default: the goal's last time step). The drive is then scored as vilma's scorecard scores its own
(:func:`vilma.world.benchmark.check_drive`, :meth:`vilma.world.commonroad.EgoTask.goal_time`), the box the planner's
vehicle (a BMW 320i, CommonRoad vehicle 2) centred where it centres it.

    python benchmarks/anchors/reactive_planner.py FILE.xml
"""

from __future__ import annotations

import json
import logging
import sys
import time
import warnings
from pathlib import Path

import numpy as np

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    from commonroad.planning.planning_problem import PlanningProblem
    from commonroad_rp.reactive_planner import ReactivePlanner
    from commonroad_rp.state import ReactivePlannerState
    from commonroad_rp.utility.config import (
        DebugConfiguration,
        PlanningConfiguration,
        ReactivePlannerConfiguration,
    )
    from commonroad_rp.utility.utils_coordinate_system import create_coordinate_system, create_initial_ref_path

from vilma.world.benchmark import EgoBox, check_drive
from vilma.world.commonroad import EgoTask, load

REPLAN_S, HORIZON_S = 0.3, 2.0
"""Its example configurations' replanning period and planning horizon [s]."""


def configuration(task: EgoTask, problem: PlanningProblem) -> ReactivePlannerConfiguration:
    """The planner's configuration for ``task`` (its ``problem``): its defaults but the example's timing, one
    process, quiet."""
    config = ReactivePlannerConfiguration(
        planning=PlanningConfiguration(dt=task.dt, replanning_frequency=round(REPLAN_S / task.dt),
                                       time_steps_computation=round(HORIZON_S / task.dt)),
        debug=DebugConfiguration(multiproc=False, logging_level="ERROR"))
    config.vehicle.update_vehicle_config({})  # the vehicle's dimensions and limits from its CommonRoad type
    config.update(scenario=task.scenario, planning_problem=problem)
    return config


def planner_for(config: ReactivePlannerConfiguration) -> ReactivePlanner:
    """The planner at the initial state, on the route planner's shortest reference path, smoothed its way."""
    path = create_initial_ref_path(config.scenario.lanelet_network, config.planning_problem)
    planner = ReactivePlanner(config)
    planner.set_reference_path(coordinate_system=create_coordinate_system(path))
    planner.record_state_and_input(planner.x_0)
    return planner


def drive(planner: ReactivePlanner, steps: int, plan_s: list[float]) -> str | None:
    """Plan and follow for at most ``steps`` time steps (the states in ``planner.record_state_list``, rear axle),
    each plan's time [s] appended to ``plan_s``; why it stopped early if a plan failed (an exception
    propagates)."""
    every, optimal = planner.config.planning.replanning_frequency, None
    while not planner.goal_reached() and len(planner.record_state_list) <= steps:
        k = (len(planner.record_state_list) - 1) % every
        if k == 0:
            planner.set_desired_velocity(current_speed=planner.x_0.velocity)
            t0 = time.perf_counter()
            optimal = planner.plan()
            plan_s.append(time.perf_counter() - t0)
            if not optimal:
                return f"no feasible trajectory at {(len(planner.record_state_list) - 1) * planner.dt:.3g} s"
        planner.record_state_and_input(optimal[0].state_list[1 + k])
        planner.reset(initial_state_cart=planner.record_state_list[-1],
                      initial_state_curv=(optimal[1][1 + k], optimal[2][1 + k]),
                      collision_checker=planner.collision_checker, coordinate_system=planner.coordinate_system)
    return None


def run(file: str | Path, time_limit: float | None = None) -> dict:
    """Drive ``file``'s first planning problem for at most ``time_limit`` [s] (default: until the goal's last
    time step) and score it: one row; ``error`` holds what the planner raised or why it stopped, if it did."""
    road = load(file)
    task = road.task()
    config = configuration(task, road.planning_problems[task.planning_problem_id])
    goal_end = max(s.time_step.end for s in config.planning_problem.goal.state_list) - task.time_step
    steps = goal_end if time_limit is None else round(time_limit / task.dt)
    error, planner, plan_s = None, None, []
    try:
        planner = planner_for(config)
        error = drive(planner, steps, plan_s)
    except Exception as e:  # a crash is a row, as in the figures, scored on its drive so far
        error = f"{type(e).__name__}: {e}".strip().splitlines()[0] if str(e).strip() else type(e).__name__
    states = planner.record_state_list if planner is not None else []
    return {"file": Path(file).name, **score(task, config, states), "plan_ms_mean": _ms(np.mean, plan_s),
            "plan_ms_max": _ms(np.max, plan_s), "cycles": len(plan_s), "steps": max(len(states) - 1, 0),
            "error": error}


def score(task: EgoTask, config: ReactivePlannerConfiguration, states: list[ReactivePlannerState]) -> dict:
    """Goal, collisions and off-road of a drive of ``states`` (one a time step, rear axle), as vilma scores its
    own."""
    if not states:
        return {"goal_reached": False, "collisions": None, "off_road": None, "time_to_goal_s": None}
    centre = [ReactivePlannerState.shift_state_to_center(s, config.vehicle.wb_rear_axle) for s in states]
    t = np.arange(len(states)) * task.dt
    x, y = (np.array([s.position[i] for s in centre]) for i in (0, 1))
    yaw, v = np.array([s.orientation for s in centre]), np.array([s.velocity for s in centre])
    box = EgoBox(length=config.vehicle.length, width=config.vehicle.width)
    found = check_drive(task, box, t, x, y, yaw, v, np.zeros_like(v))
    goal = task.goal_time(t, x, y, yaw, v)
    return {"goal_reached": goal is not None, "collisions": len(found.hit),
            "off_road": found.off_road_time is not None, "time_to_goal_s": goal}


def _ms(f, seconds: list[float]) -> float | None:
    return round(float(f(seconds)) * 1e3, 1) if seconds else None


if __name__ == "__main__":
    logging.disable(logging.WARNING)
    print(json.dumps(run(sys.argv[1]), indent=1))
