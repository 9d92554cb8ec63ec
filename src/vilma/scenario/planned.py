"""A planned run (``task: {plan: ...}``): each replan period the car perceives, predicts, plans and hands the plan to
the driver; its perception is scored against the true traffic on every scan.

Perception is ``truth`` (the objects sensor's noisy true objects taken as tracks with their velocities) or
``laser`` (each scan segmented, boxed and tracked: :mod:`vilma.perception`). The tracks' futures are predicted at
constant velocity over the planner's horizon and the plan (:func:`vilma.planning.plan`) starts from the car's
estimated state in the route's Frenet frame; a planner with no free candidate stops the car (its fallback),
which the scorecard counts, with the last reason.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence

import numpy as np

from vilma.control.driver import Driver
from vilma.core.messages import Message, ObjectList, PointCloud, PoseEstimate
from vilma.perception import (
    MotFrame,
    SegmentParams,
    Track,
    Tracker,
    clear_mot,
    fit_boxes,
    laser_pose,
    predict,
    scan_points,
    segment,
)
from vilma.planning import FrenetFrame, FrenetState, Plan, RoadBounds, plan
from vilma.scenario.plan_keys import PLANNER
from vilma.scenario.spec import Scenario
from vilma.sim import SimConfig
from vilma.trajectory import Trajectory
from vilma.world.states import YAW, V, X, Y

MOT_THRESHOLD = 2.5
"""Farthest a track may be from a true object to match it in the CLEAR MOT scores [m]: half a car's length and
a bit, since a laser box spans only the faces the laser sees (its centre is up to half the car's length off)."""
RESYNC_SPEED = 1.0
"""A plan starts from the speed of the plan driven while the car's is within this of it [m/s]
(:meth:`Planning._start`)."""
KEEP_OFFSET = 0.1
"""A plan whose lateral motion ends farther than this from the car [m] is a lane change under way, which the next
plan may keep (:meth:`Planning._start`)."""
RESYNC_OFFSET = 0.5
"""A plan starts from the lane offset of the plan driven while the car's is within this of it [m]
(:meth:`Planning._start`)."""
CREEP_SPEED = 0.5
"""Below this speed [m/s] a plan keeps the car's lane offset, and a plan that stops within :data:`STOP_REACH` is
the driver's stop on its end (replanned each cycle from a crawl, a stop's gentle polynomial would approach its end
ever more slowly, never there)."""
STOP_REACH = 1.0
"""How near [m] the end of a plan that stops is for the car at a crawl to stop on it at once."""
PREVIEW = 1.0
"""How far ahead in the plan the speed controller aims [s]: about the lag of a speed loop (pi_ff's 1 / kp, 0.83 s,
and its shaped reference's)."""
PLANNING_KEYS = ("perception", "planner", "planning_cycles", "planning_ms_mean", "planning_ms_max",
                 "planner_fallbacks", "planner_reason", "mota", "motp_m", "detection_precision", "detection_recall",
                 "tracking_position_rmse_m", "tracking_velocity_rmse_mps", "identity_switches")
"""The scorecard keys of a planned run."""


class Planning:
    """The perception and planning of one planned car: :meth:`perceive` each block's scans, :meth:`cycle` now and
    each replan period (:meth:`period_done` each driver period), :meth:`scores` at the end.

    ``path`` is the route with its speeds, ending at the goal (:meth:`~vilma.scenario.spec.Scenario.reference_path`).
    """

    def __init__(self, scenario: Scenario, path: Trajectory, driver: Driver, sim: SimConfig) -> None:
        self.params, self.kind, self.sim, self.driver, self.path = scenario.planner, scenario.perception, sim, \
            driver, path
        self.frame = FrenetFrame(path)
        self.road = RoadBounds(path.s, *scenario.road.network.lateral_bounds(path.xy)) if scenario.road else None
        (self.goal,), _ = self.frame.to_frenet([path.xy[-1, 0]], [path.xy[-1, 1]])
        self.every, self.periods = round(self.params.replan_period / driver.period), 0
        self.preview = round(PREVIEW / self.params.dt)
        self.tracker = Tracker()
        self.tracks: list[Track] = []
        self.frames: list[MotFrame] = []
        self.last: tuple[float, Plan] | None = None  # when the driven plan began [s], and the plan
        self.cycles = self.fallbacks = 0
        self.reason: str | None = None
        self.spent_ms = [0.0, 0.0]  # total and longest [ms]
        if self.kind == "laser":
            p = sim.laser
            self.bearings, self.mount = p.bearings, (*p.position[:2], p.yaw)
            self.segments = SegmentParams(range_noise=p.range_noise)

    def perceive(self, captures: Sequence[tuple[str, Message]], pose: PoseEstimate | None,
                 truth: tuple[float, float, float]) -> None:
        """Take a block's scans (the simulator's captures) seen from the estimated ``pose``; ``truth`` is the car's
        true x, y [m] and yaw [rad], to score the scans against the objects within the sensor's reach."""
        for _, msg in captures:
            if self.kind == "truth" and isinstance(msg, ObjectList):
                self.tracks = [_track(o) for o in msg.objects]
                self._score(msg.stamp_ns, truth[:2], self.sim.objects.range)
            elif self.kind == "laser" and isinstance(msg, PointCloud) and pose is not None:
                self.tracks = self.tracker.update(msg.stamp_ns, self._boxes(msg, pose))
                self._score(msg.stamp_ns, laser_pose(truth, self.mount)[:2], self.sim.laser.max_range)

    def _boxes(self, scan: PointCloud, pose: PoseEstimate) -> np.ndarray:
        """The boxes (n, 5) of a scan's clusters in the world frame."""
        ranges = np.frombuffer(scan.ranges, "<f4").astype(np.float64)
        clusters = segment(ranges, self.bearings, self.segments)
        return fit_boxes(scan_points(ranges, self.bearings), clusters,
                         laser_pose((pose.x, pose.y, pose.yaw), self.mount))

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

    def period_done(self, t: float) -> None:
        """A driver period ended at sim time ``t`` [s]: plan if a replan period is over."""
        self.periods += 1
        if self.periods % self.every == 0:
            self.cycle(t)

    def cycle(self, t: float) -> None:
        """Plan at sim time ``t`` [s] from the car's estimated state and hand the plan to the driver."""
        est = self.driver.estimator.estimate
        if est is None:
            return
        t0 = time.perf_counter()
        params = dataclasses.replace(self.params, target_speed=self._speed_ahead(est.x, est.y))
        state, keep = self._start(est, t, params)
        result = plan(state, self.frame, predict(self.tracks, params.times), params, goal=self.goal, keep=keep,
                      **({} if self.road is None else {"road": self.road}))
        spent = (time.perf_counter() - t0) * 1e3
        self.spent_ms = [self.spent_ms[0] + spent, max(self.spent_ms[1], spent)]
        self.cycles += 1
        if result.mode == "fallback":
            self.fallbacks += 1
            self.reason = result.reason
        self.last = (t, result)
        path = _previewed(result, self.preview)
        if est.speed < CREEP_SPEED and result.speed[-1] < self.driver.params.rest_speed and _reach(path) < STOP_REACH:
            path = Trajectory(path.xy, np.zeros(len(path)))  # the driver's stop on its end, now
        self.driver.drive_plan(path)

    def _speed_ahead(self, x: float, y: float) -> float:
        """The route's speed for the car at ``(x, y)`` [m] [m/s]: the lowest from which it brakes at its comfortable
        deceleration to the route's speed at every point ahead (so it slows before a bend or a lower limit, not
        in it)."""
        s, speed = self.path.s, self.path.speed
        k = min(int(np.searchsorted(s, self.path.project(x, y).s)), len(s) - 1)
        b = self.params.vehicle.actuators.stop_deceleration
        return float(np.sqrt(np.maximum(speed[k:], 0.0) ** 2 + 2.0 * b * (s[k:] - s[k])).min())

    def _start(self, est: PoseEstimate, t: float, params) -> tuple[FrenetState, tuple[float, float] | None]:
        """Where the plan starts at sim time ``t`` [s]: the car's estimated position in the Frenet frame; its speed
        the faster of the estimate's and the driven plan's then, with the plan's acceleration, while the two are
        within :data:`RESYNC_SPEED` (Werling's consistent replanning: started from the estimate alone each plan would
        start behind the speed controller; never slower than the car, which would brake late), else the estimate's
        at no acceleration; its lane offset and its rates the driven plan's while within :data:`RESYNC_OFFSET` of
        the estimate's, and then the rest of a lane change under way (``keep`` of :func:`plan`,
        :data:`KEEP_OFFSET`), else a lane change, started over each cycle from where the path controller lags it,
        would never get on. Below
        :data:`CREEP_SPEED` the car holds its lane offset: the planner's lateral motions in time are infeasible
        there (a curvature over speed squared), and a manoeuvre at walking pace is none."""
        curvature = est.yaw_rate / est.speed if abs(est.speed) > CREEP_SPEED else 0.0  # none turning on the spot
        now = self.frame.state(est.x, est.y, est.yaw, est.speed, 0.0, curvature)
        keep = None
        if self.last is not None:
            began, last = self.last
            planned = last.state_at(t - began)
            if abs(planned.s_dot - now.s_dot) <= RESYNC_SPEED:  # never slower than the car: it would brake late
                now = now._replace(s_dot=max(planned.s_dot, now.s_dot), s_ddot=planned.s_ddot)
            if abs(planned.d - now.d) <= RESYNC_OFFSET:
                now = now._replace(d=planned.d, d_dot=planned.d_dot, d_ddot=planned.d_ddot)
                if last.lateral is not None and last.lateral[1] - (t - began) >= params.dt and \
                        abs(last.lateral[0] - now.d) > KEEP_OFFSET:
                    keep = (last.lateral[0], last.lateral[1] - (t - began))
        if now.s_dot < CREEP_SPEED:
            offsets = np.asarray(params.lateral_offsets)
            now, keep = now._replace(d=float(offsets[np.argmin(np.abs(offsets - now.d))]), d_dot=0.0, d_ddot=0.0), None
        return now, keep

    def at_goal(self, x: float, y: float, tolerance: float) -> bool:
        """Whether ``(x, y)`` [m] is within ``tolerance`` [m] of the goal."""
        return math.hypot(x - self.path.xy[-1, 0], y - self.path.xy[-1, 1]) <= tolerance

    def scores(self) -> dict:
        """The scorecard's planning keys (:data:`PLANNING_KEYS`); NaN where a score is undefined."""
        mot = clear_mot(self.frames, MOT_THRESHOLD)
        total, longest = self.spent_ms if self.cycles else (math.nan, math.nan)
        return dict(zip(PLANNING_KEYS, (
            self.kind, PLANNER, self.cycles, total / max(self.cycles, 1), longest, self.fallbacks, self.reason,
            mot.mota, mot.motp, mot.precision, mot.recall, mot.position_rmse, mot.velocity_rmse, mot.id_switches),
            strict=True))


def _previewed(p: Plan, steps: int) -> Trajectory:
    """The plan's path with at each point the speed planned ``steps`` later (the last one held): the speed
    controller, which aims at the speed where the car is, then leads the plan by that much as it accelerates or
    brakes, instead of lagging it."""
    speed = p.speed[np.minimum(np.arange(len(p.speed)) + steps, len(p.speed) - 1)]
    return Trajectory(np.column_stack([p.x, p.y]), speed)


def _reach(path: Trajectory) -> float:
    """How far the end of ``path`` is from its start [m]."""
    return float(np.hypot(*(path.xy[-1] - path.xy[0])))


def _track(o) -> Track:
    """An object of the objects sensor as a track (its velocity along its orientation)."""
    return Track(o.id, o.x, o.y, o.yaw, o.speed * math.cos(o.yaw), o.speed * math.sin(o.yaw), o.length, o.width,
                 np.zeros((4, 4)), 0.0)
