"""A planned run (``task: {plan: ...}``): the car's local planning
(:class:`~vilma.control.local_planning.LocalPlanning`), its perception scored against the true traffic on every scan
(CLEAR MOT; the objects within the sensor's range and field of view), the scorecard's planning keys, and its tracks
and plans as bus messages for the run's observers."""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from vilma.control.driver import Driver
from vilma.control.local_planning import LocalPlanning, road_bounds
from vilma.core.geometry import wrap_angle
from vilma.core.messages import MAX_TRACKS, Message, PoseEstimate
from vilma.perception import MotFrame, clear_mot, laser_pose
from vilma.planning import NO_ROAD, Plan, RoadBounds, local_plan, track_list
from vilma.scenario.plan_keys import PLANNER, PLANNING_KEYS
from vilma.scenario.result import PlanningLog
from vilma.scenario.spec import Scenario
from vilma.sim import SimConfig
from vilma.trajectory import Arrival, Trajectory
from vilma.world.states import YAW, V, X, Y

if TYPE_CHECKING:  # the roads extra
    from vilma.world.commonroad import RoadNetwork

MOT_THRESHOLD = 2.5
"""Farthest a track may be from a true object to match it in the CLEAR MOT scores [m]: half a car's length and
a bit, since a laser box spans only the faces the laser sees (its centre is up to half the car's length off)."""
RECORDED_CANDIDATES = 30
"""The most candidates a recorded plan carries (:func:`~vilma.planning.local_plan`): half the live view's, for
a recording about half the size (a plan is mostly its candidates)."""


class Planning(LocalPlanning):
    """The perception and planning of one planned car, scored: :meth:`perceive` each block's scans, :meth:`cycle`
    now and each replan period (:meth:`period_done` each driver period), :meth:`scores` at the end. The tracks after
    each scan and each cycle's plan wait in :attr:`messages` (bus messages) for the runner to hand on and clear.

    ``path`` is the route with its speeds, ending at the goal (:meth:`~vilma.scenario.spec.Scenario.reference_path`);
    ``observed``: whether anyone takes the messages (else none are made: a tenth of an unobserved run's time).
    """

    def __init__(self, scenario: Scenario, path: Trajectory, driver: Driver, sim: SimConfig,
                 observed: bool = True) -> None:
        road = scenario.road
        super().__init__(scenario.planner, scenario.perception, sim.laser, path, driver,
                         _road_bounds(road.network, path.xy.tobytes()) if road else NO_ROAD,
                         tuple(Arrival(*w) for w in road.arrivals) if road else (),
                         road.network.lanes if road else None)
        self.sim, self.observed = sim, observed
        self._radius = np.zeros(0) if sim.traffic is None else np.hypot(*sim.traffic.outline.T).max(axis=0)
        """Each obstacle's outline's farthest point from its reference point [m]."""
        self.frames: list[MotFrame] = []
        self.log = PlanningLog()
        self.messages: list[tuple[str, Message]] = []
        """``perception/objects`` and ``planning/plan`` messages since the runner last took them."""

    def perceive(self, captures: Sequence[tuple[str, Message]], pose: PoseEstimate | None,
                 truth: tuple[float, float, float]) -> None:
        """Take a block's scans (the simulator's captures) seen from the estimated ``pose``; ``truth`` is the car's
        true x, y [m] and yaw [rad], to score the scans against the objects the sensor can see (:meth:`_score`)."""
        for _, msg in captures:
            if self.take(msg, pose):
                self.log.scan_t.append(msg.stamp_ns * 1e-9)
                self.log.tracks.append(len(self.tracks))
                if self.observed:
                    self.messages.append(("perception/objects", track_list(msg.stamp_ns, self.kind,
                                                                           self.tracks[:MAX_TRACKS])))
                if self.kind == "truth":
                    self._score(msg.stamp_ns, truth, self.sim.objects.range, 2.0 * math.pi)
                else:
                    self._score(msg.stamp_ns, laser_pose(truth, self.mount), self.sim.laser.max_range,
                                math.radians(self.sim.laser.fov))

    def cycle(self, t: float) -> Plan | None:
        """Plan at sim time ``t`` [s] (:meth:`LocalPlanning.cycle`), kept in :attr:`log` and :attr:`messages`."""
        result = super().cycle(t)
        if result is not None:
            self.log.cycle_t.append(t)
            self.log.cycle_ms.append(self.last_ms)
            self.log.modes.append(result.mode)
            if self.observed:
                self.messages.append(("planning/plan", local_plan(
                    round(t * 1e9), result, self.predicted_tracks[:MAX_TRACKS], self.predicted[:MAX_TRACKS],
                    RECORDED_CANDIDATES, self.last_ms)))
        return result

    def _score(self, stamp_ns: int, sensor: tuple[float, float, float], reach: float, fov: float) -> None:
        """A CLEAR MOT frame: the tracks now against the true objects the sensor at ``sensor`` (x, y [m], yaw [rad])
        can see: centred within ``reach`` [m], and some part of them (the circle round their outline) within its
        field of view ``fov`` [rad] about its yaw (a forward laser cannot miss what is behind it)."""
        ids, s = np.zeros(0, np.int64), np.zeros((0, 4))
        if self.sim.traffic is not None:
            states, present = self.sim.traffic.at(stamp_ns * 1e-9 + self.sim.traffic_t0)
            dx, dy = states[:, X] - sensor[0], states[:, Y] - sensor[1]
            gap = np.hypot(dx, dy)
            near = present & (gap <= reach)
            if fov < 2.0 * math.pi:
                half = np.arcsin(np.minimum(self._radius / np.maximum(gap, 1e-9), 1.0))  # the outline's half angle
                near &= np.abs(wrap_angle(np.arctan2(dy, dx) - sensor[2])) <= 0.5 * fov + half
            ids, s = self.sim.traffic.ids[near], states[near]
        tracks = np.array([(t.id, t.x, t.y, t.vx, t.vy) for t in self.tracks]).reshape(-1, 5)
        heading = np.array([np.cos(s[:, YAW]), np.sin(s[:, YAW])]).T  # not column_stack: a scan's time counts
        self.frames.append(MotFrame(ids, s[:, X:Y + 1], s[:, V, None] * heading, tracks[:, 0].astype(np.int64),
                                    tracks[:, 1:3], tracks[:, 3:]))

    def scores(self) -> dict:
        """The scorecard's planning keys (:data:`PLANNING_KEYS`); NaN where a score is undefined."""
        mot = clear_mot(self.frames, MOT_THRESHOLD)
        total, longest = self.spent_ms if self.cycles else (math.nan, math.nan)
        return dict(zip(PLANNING_KEYS, (
            self.kind, PLANNER, self.cycles, total / max(self.cycles, 1), longest, self.fallbacks, self.evasions,
            self.reason, mot.mota, mot.motp, mot.precision, mot.recall, mot.position_rmse, mot.velocity_rmse,
            mot.id_switches), strict=True))


@lru_cache(maxsize=8)  # a benchmark or a sweep plans one route many times, its path made anew (alike) each run
def _road_bounds(network: RoadNetwork, xy: bytes) -> RoadBounds:
    """:func:`~vilma.control.local_planning.road_bounds` on ``network`` of the route through the points ``xy`` (x, y
    pairs, float64) [m]: read-only, shared by the runs."""
    bounds = road_bounds(network, Trajectory(np.frombuffer(xy).reshape(-1, 2)))
    for a in bounds:
        a.flags.writeable = False
    return bounds
