"""Local motion planning: the Frenet frame of a reference path, boundary-value polynomials, the sampling planner."""

from vilma.planning.frenet import FrenetFrame, FrenetState
from vilma.planning.messages import local_plan, track_list
from vilma.planning.params import PlannerParams
from vilma.planning.planner import NO_ROAD, Candidates, Plan, RoadBounds, Status, plan

__all__ = ["NO_ROAD", "Candidates", "FrenetFrame", "FrenetState", "Plan", "PlannerParams", "RoadBounds", "Status",
           "local_plan", "plan", "track_list"]
