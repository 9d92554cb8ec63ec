"""Writing the CommonRoad files some scenario tests build with commonroad-io."""

from __future__ import annotations

import importlib.resources
import warnings
from pathlib import Path

import numpy as np

TUTORIAL = Path(str(importlib.resources.files("vilma") / "scenarios/data/commonroad/ZAM_Tutorial-1_1_T-1.xml"))


def write_commonroad(scenario, planning_problems, out: Path) -> Path:
    """Write ``scenario`` and its ``PlanningProblemSet`` to ``out`` with commonroad-io's own writer; returns ``out``."""
    with warnings.catch_warnings():  # commonroad-io's protobuf writer warns of deprecated calls on import
        warnings.simplefilter("ignore")
        from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile

        CommonRoadFileWriter(scenario, planning_problems, author="vilma tests", affiliation="", source="",
                             tags=set()).write_to_file(str(out), OverwriteExistingFile.ALWAYS)
    return out


def tutorial_with_car(out: Path, ego: tuple[float, float], car: np.ndarray, length: float = 4.5,
                      width: float = 2.0) -> Path:
    """CommonRoad's tutorial road (three straight lanes along +x, centres y = 0, 3.5, 7) with its obstacle removed,
    the ego at x = ``ego[0]`` [m] at ``ego[1]`` [m/s] in the lane y = 0, and one car of ``length`` x ``width`` [m]
    heading +x: ``car`` (steps, 3) its x, y [m] and speed [m/s] at time steps 0, 1, ... (one row: parked there).
    Written to ``out``; returns ``out``."""
    from commonroad.geometry.shape import Rectangle
    from commonroad.planning.planning_problem import PlanningProblemSet
    from commonroad.prediction.prediction import TrajectoryPrediction
    from commonroad.scenario.obstacle import DynamicObstacle, ObstacleType, StaticObstacle
    from commonroad.scenario.state import CustomState, InitialState
    from commonroad.scenario.trajectory import Trajectory

    from vilma.world.commonroad import load

    road = load(TUTORIAL)
    sc = road.scenario
    for o in list(sc.obstacles):
        sc.remove_obstacle(o)
    pp = next(iter(road.planning_problems.values()))
    pp.initial_state.position, pp.initial_state.velocity = np.array([ego[0], 0.0]), ego[1]
    shape = Rectangle(length, width)
    (x0, y0, v0), car = car[0], np.asarray(car, float)
    init = InitialState(time_step=0, position=np.array([x0, y0]), orientation=0.0, velocity=float(v0),
                        acceleration=0.0, yaw_rate=0.0, slip_angle=0.0)
    if len(car) == 1:
        sc.add_objects(StaticObstacle(sc.generate_object_id(), ObstacleType.PARKED_VEHICLE, shape, init))
    else:
        states = [CustomState(time_step=k, position=np.array([x, y]), orientation=0.0, velocity=float(v))
                  for k, (x, y, v) in enumerate(car) if k > 0]
        sc.add_objects(DynamicObstacle(sc.generate_object_id(), ObstacleType.CAR, shape, init,
                                       TrajectoryPrediction(Trajectory(1, states), shape)))
    return write_commonroad(sc, PlanningProblemSet([pp]), out)
