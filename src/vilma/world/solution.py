"""A drive as a CommonRoad solution file (``solution.xml``), written with commonroad-io's own writer.

The trajectory is of CommonRoad's single-track model (``ST``, vehicle model of Althoff et al.), whose state is
vilma's single-track state at the centre of mass: position, steering angle, speed ``hypot(vx, vy)``,
orientation, yaw rate and slip angle ``atan2(vy, vx)``, at the scenario's time steps. The vehicle type is the
benchmark's car closest to vilma's: the BMW 320i (type 2) for the ``bmw_320i`` preset, whose parameters it is,
else the Ford Escort (type 1; 1225 kg and 2.39 m wheelbase against the vilma car's 1211 kg and 2.45 m).
"""

from __future__ import annotations

import warnings

import numpy as np

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    from commonroad.common.solution import (
        CommonRoadSolutionWriter,
        CostFunction,
        PlanningProblemSolution,
        Solution,
        VehicleModel,
        VehicleType,
    )
    from commonroad.scenario.state import STState
    from commonroad.scenario.trajectory import Trajectory

from vilma.world.commonroad import EgoTask

COST_FUNCTION = CostFunction.WX1
"""The benchmark's cost function the solution names (WX1: the default of its examples)."""


def vehicle_type(preset: str) -> VehicleType:
    """The benchmark's vehicle type for a vilma car preset name."""
    return VehicleType.BMW_320i if preset == "bmw_320i" else VehicleType.FORD_ESCORT


def solution_xml(task: EgoTask, preset: str, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray,
                 vx: np.ndarray, vy: np.ndarray, yaw_rate: np.ndarray, steer: np.ndarray) -> str:
    """The solution file's text for a drive: samples at times ``t`` [s] after the initial state of the centre
    of mass's position [m], yaw [rad], body-frame velocity [m/s], yaw rate [rad/s] and steering angle [rad]. The
    first state is the planning problem's initial state (driving straight: no steering, yaw
    rate or slip), where the drive began."""
    start = STState(time_step=task.time_step, position=np.array([task.x, task.y]), steering_angle=0.0,
                    velocity=task.speed, orientation=task.yaw, yaw_rate=0.0, slip_angle=0.0)
    states = [start, *(STState(time_step=task.time_step + k, position=np.array([x[i], y[i]]),
                               steering_angle=float(steer[i]), velocity=float(np.hypot(vx[i], vy[i])),
                               orientation=float(yaw[i]), yaw_rate=float(yaw_rate[i]),
                               slip_angle=float(np.arctan2(vy[i], vx[i])))
                       for k, i in enumerate(task.samples(t)) if k > 0)]
    solved = PlanningProblemSolution(planning_problem_id=task.planning_problem_id, vehicle_model=VehicleModel.ST,
                                     vehicle_type=vehicle_type(preset), cost_function=COST_FUNCTION,
                                     trajectory=Trajectory(task.time_step, states))
    solution = Solution(scenario_id=task.scenario.scenario_id, planning_problem_solutions=[solved])
    return CommonRoadSolutionWriter(solution).dump()
