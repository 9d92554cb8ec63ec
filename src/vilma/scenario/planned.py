"""A planned run (``task: {plan: ...}``): the car's local planning
(:class:`~vilma.control.local_planning.LocalPlanning`), its perception scored against the true traffic on every scan
(CLEAR MOT), and the scorecard's planning keys."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vilma.control.driver import Driver
from vilma.control.local_planning import LocalPlanning
from vilma.core.messages import Message, PoseEstimate
from vilma.perception import MotFrame, clear_mot, laser_pose
from vilma.planning import NO_ROAD, RoadBounds
from vilma.scenario.plan_keys import PLANNER
from vilma.scenario.spec import Scenario
from vilma.sim import SimConfig
from vilma.trajectory import Trajectory
from vilma.world.states import YAW, V, X, Y

MOT_THRESHOLD = 2.5
"""Farthest a track may be from a true object to match it in the CLEAR MOT scores [m]: half a car's length and
a bit, since a laser box spans only the faces the laser sees (its centre is up to half the car's length off)."""
PLANNING_KEYS = ("perception", "planner", "planning_cycles", "planning_ms_mean", "planning_ms_max",
                 "planner_fallbacks", "planner_reason", "mota", "motp_m", "detection_precision", "detection_recall",
                 "tracking_position_rmse_m", "tracking_velocity_rmse_mps", "identity_switches")
"""The scorecard keys of a planned run."""


class Planning(LocalPlanning):
    """The perception and planning of one planned car, scored: :meth:`perceive` each block's scans, :meth:`cycle`
    now and each replan period (:meth:`period_done` each driver period), :meth:`scores` at the end.

    ``path`` is the route with its speeds, ending at the goal (:meth:`~vilma.scenario.spec.Scenario.reference_path`).
    """

    def __init__(self, scenario: Scenario, path: Trajectory, driver: Driver, sim: SimConfig) -> None:
        road = scenario.road
        super().__init__(scenario.planner, scenario.perception, sim.laser, path, driver,
                         RoadBounds(path.s, *road.network.lateral_bounds(path.xy)) if road else NO_ROAD)
        self.sim = sim
        self.frames: list[MotFrame] = []

    def perceive(self, captures: Sequence[tuple[str, Message]], pose: PoseEstimate | None,
                 truth: tuple[float, float, float]) -> None:
        """Take a block's scans (the simulator's captures) seen from the estimated ``pose``; ``truth`` is the car's
        true x, y [m] and yaw [rad], to score the scans against the objects within the sensor's reach."""
        for _, msg in captures:
            if self.take(msg, pose):
                if self.kind == "truth":
                    self._score(msg.stamp_ns, truth[:2], self.sim.objects.range)
                else:
                    self._score(msg.stamp_ns, laser_pose(truth, self.mount)[:2], self.sim.laser.max_range)

    def _score(self, stamp_ns: int, centre: tuple[float, float], reach: float) -> None:
        """A CLEAR MOT frame: the tracks now against the true objects within ``reach`` [m] of ``centre``."""
        ids, s = np.zeros(0, np.int64), np.zeros((0, 4))
        if self.sim.traffic is not None:
            states, present = self.sim.traffic.at(stamp_ns * 1e-9 + self.sim.traffic_t0)
            near = present & (np.hypot(states[:, X] - centre[0], states[:, Y] - centre[1]) <= reach)
            ids, s = self.sim.traffic.ids[near], states[near]
        tracks = np.array([(t.id, t.x, t.y, t.vx, t.vy) for t in self.tracks]).reshape(-1, 5)
        self.frames.append(MotFrame(ids, s[:, [X, Y]], s[:, V, None] * np.column_stack([np.cos(s[:, YAW]),
                                                                                        np.sin(s[:, YAW])]),
                                    tracks[:, 0].astype(np.int64), tracks[:, 1:3], tracks[:, 3:]))

    def scores(self) -> dict:
        """The scorecard's planning keys (:data:`PLANNING_KEYS`); NaN where a score is undefined."""
        mot = clear_mot(self.frames, MOT_THRESHOLD)
        total, longest = self.spent_ms if self.cycles else (math.nan, math.nan)
        return dict(zip(PLANNING_KEYS, (
            self.kind, PLANNER, self.cycles, total / max(self.cycles, 1), longest, self.fallbacks, self.reason,
            mot.mota, mot.motp, mot.precision, mot.recall, mot.position_rmse, mot.velocity_rmse, mot.id_switches),
            strict=True))
