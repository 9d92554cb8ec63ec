"""A plan task's sections of a scenario file: ``planner`` and ``perception`` (:mod:`vilma.scenario.spec` reads the
rest), and its route cut at the goal."""

from __future__ import annotations

from typing import TYPE_CHECKING

from vilma.scenario.fields import Source, build, get
from vilma.scenario.task import TaskSpec
from vilma.sim import SimConfig
from vilma.sim.config import MUJOCO

if TYPE_CHECKING:  # the planner (numba, scipy.interpolate) is imported for a plan only
    from vilma.planning import PlannerParams

PERCEPTION = ("truth", "laser")
"""What a plan perceives with (``perception``)."""
PLANNER = "werling"
"""The local planner that drives a ``plan`` task (:func:`vilma.planning.plan`), as the scorecard names it."""
PLANNING_KEYS = ("perception", "planner", "planning_cycles", "planning_ms_mean", "planning_ms_max",
                 "planner_fallbacks", "planner_evasions", "planner_reason", "mota", "motp_m", "detection_precision",
                 "detection_recall", "tracking_position_rmse_m", "tracking_velocity_rmse_mps", "identity_switches")
"""The scorecard keys of a planned run (:mod:`vilma.scenario.planned`)."""


def read_planner(data: dict, src: Source, task: TaskSpec, sim: SimConfig, period: float) -> PlannerParams | None:
    """``planner``: a plan task's :class:`~vilma.planning.PlannerParams` for the scenario's car, its replan period
    a whole number of driver periods of ``period`` [s]."""
    if task.plan is None:
        if "planner" in data:
            raise src.error(("planner",), "only for a plan task: add task: {plan: true} or remove it")
        return None
    from vilma.control.local_planning import default_planner  # numba and scipy.interpolate: for a plan only
    from vilma.planning import PlannerParams
    raw = data.get("planner") or {}
    for name, where in (("vehicle", "vehicle"), ("target_speed", "task.speed")):
        if isinstance(raw, dict) and name in raw:
            raise src.error(("planner", name), f"set by the scenario's {where}; remove it here")
    params = build(PlannerParams, raw, src, ("planner",), default_planner(sim.vehicle))
    cycles = params.replan_period / period
    if abs(cycles - round(cycles)) > 1e-9:
        raise src.error(("planner", "replan_period"), f"{params.replan_period:g} s is not a whole number of driver "
                                                      f"periods of {period:g} s; make it one")
    return params


def read_perception(data: dict, src: Source, task: TaskSpec, sim: SimConfig) -> str | None:
    """``perception``: ``truth`` (default) or ``laser`` (which needs the ``laser`` sensor), for a plan task."""
    if task.plan is None:
        if "perception" in data:
            raise src.error(("perception",), "only for a plan task: add task: {plan: true} or remove it")
        return None
    value = get(data, src, ("perception",), str, "truth")
    if value not in PERCEPTION:
        raise src.error(("perception",), f"unknown perception {value!r}; use one of {', '.join(PERCEPTION)}")
    if value == "laser" and sim.laser is None:
        raise src.error(("perception",), "laser perception needs the laser sensor: add 'laser: true'")
    if value == "laser" and sim.model == MUJOCO:
        raise src.error(("perception",), "laser perception reads the flat-ground laser: give another plant than "
                                         f"{MUJOCO}")
    return value
