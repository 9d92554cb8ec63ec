"""Local planning for the driver: each replan period perceive, predict, plan and hand the plan to the driver.

Perception is ``truth`` (the objects sensor's noisy true objects taken as tracks with their velocities) or
``laser`` (each scan segmented, boxed and tracked: :mod:`vilma.perception`). The tracks' futures are predicted over
the planner's horizon along each way on their lane where the road's lanes are known, else at constant velocity,
and the plan (:func:`vilma.planning.plan`) starts from the car's estimated state in the route's Frenet frame; a
planner with no free candidate stops the car (its fallback). The batch runner (:mod:`vilma.scenario.planned`, which
scores it) and the bus's driver node run it alike.
"""

from __future__ import annotations

import dataclasses
import math
import time
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from vilma.control.driver import Driver
from vilma.core.messages import Message, ObjectList, PointCloud, PoseEstimate
from vilma.perception import SegmentParams, Track, Tracker, fit_boxes, laser_pose, predict, scan_points, segment
from vilma.planning import NO_ROAD, FrenetFrame, FrenetState, Plan, PlannerParams, RoadBounds, plan
from vilma.plant3d.laser import LaserParams
from vilma.trajectory import Arrival, Trajectory
from vilma.vehicle.params import VehicleParams
from vilma.world.lanes import Lanes

if TYPE_CHECKING:  # the roads extra
    from vilma.world.commonroad import RoadNetwork

REPLAN_PERIOD = 0.1
"""A plan's replan period unless a scenario's ``planner`` sets it [s]."""
RESYNC_SPEED = 1.0
"""A plan starts from the speed of the plan driven while the car's is within this of it [m/s]
(:meth:`LocalPlanning._start`)."""
KEEP_OFFSET = 0.1
"""A plan whose lateral motion ends farther than this from the car [m] is a lane change under way, which the next
plan may keep (:meth:`LocalPlanning._start`)."""
RESYNC_OFFSET = 0.5
"""A plan starts from the lane offset of the plan driven while the car's is within this of it [m]
(:meth:`LocalPlanning._start`)."""
CREEP_SPEED = 0.5
"""Below this speed [m/s] a plan keeps the car's lane offset, and a plan that stops within :data:`STOP_REACH` is
the driver's stop on its end (replanned each cycle from a crawl, a stop's gentle polynomial would approach its end
ever more slowly, never there)."""
STOP_REACH = 1.0
"""How near [m] the end of a plan that stops is for the car at a crawl to stop on it at once."""
ROAD_SPACING = 0.5
"""How far apart along the route the road's edges are found [m]: a fraction of a car's length."""
LANE_SPEED = 1.0
"""A track slower than this [m/s] is predicted straight on (standing, its direction of motion is noise)."""
LANE_REACH_STEP = 10.0
"""A track's reach along its lane [m] (its speed over the horizon and its length) is rounded up to this, so that
the tracks on a segment share their ways."""
PREVIEW = 1.0
"""How far ahead in the plan the speed controller aims [s]: about the lag of a speed loop (pi_ff's 1 / kp, 0.83 s,
and its shaped reference's)."""


def default_planner(vehicle: VehicleParams) -> PlannerParams:
    """The planner's parameters for ``vehicle`` where nothing sets them."""
    return PlannerParams(vehicle=vehicle, replan_period=REPLAN_PERIOD)


def road_bounds(network: RoadNetwork, path: Trajectory) -> RoadBounds:
    """The edges of the road of ``network`` (its ``lateral_bounds``) across ``path`` every :data:`ROAD_SPACING` and
    at its end (a route's points are closer: a line across the road for each cost a tenth of a second a run)."""
    s = np.append(np.arange(0.0, path.length, ROAD_SPACING), path.length)
    xy = np.column_stack([np.interp(s, path.s, path.xy[:, 0]), np.interp(s, path.s, path.xy[:, 1])])
    return RoadBounds(s, *network.lateral_bounds(xy))


class LocalPlanning:
    """The perception and planning of one planned car: :meth:`take` each scan, :meth:`cycle` now and each
    replan period (:meth:`period_done` each driver period).

    ``kind`` is the perception: ``truth`` (the objects sensor's lists, topic ``objects``) or ``laser`` (the scans
    of ``laser``, topic ``laser``); ``path`` the route with its speeds, ending at the goal; ``road`` its road's
    edges, if known; ``arrivals`` the goal region's windows along ``path``, times on the sim clock (``arrivals`` of
    :func:`~vilma.planning.plan`); ``lanes`` the road's lanes to predict along, if known.

    Raises:
        ValueError: a laser perception without a laser, or a replan period that is not a whole number of driver
            periods.
    """

    def __init__(self, params: PlannerParams, kind: str, laser: LaserParams | None, path: Trajectory,
                 driver: Driver, road: RoadBounds = NO_ROAD, arrivals: tuple[Arrival, ...] = (),
                 lanes: Lanes | None = None) -> None:
        if kind == "laser" and laser is None:
            raise ValueError("laser perception needs the laser sensor: start the driver with the scenario's laser")
        every = params.replan_period / driver.period
        if abs(every - round(every)) > 1e-9:
            raise ValueError(f"planner replan_period {params.replan_period:g} s is not a whole number of driver "
                             f"periods of {driver.period:g} s; make it one")
        self.params, self.kind, self.driver, self.path, self.road = params, kind, driver, path, road
        self.arrivals, self.lanes = arrivals, lanes
        self._on: dict[int, int] = {}  # the lane segment each track was on at the last cycle
        self._targeted = params  # the parameters of the last cycle (:meth:`_targeting`)
        self.frame = FrenetFrame(path)
        (self.goal,), _ = self.frame.to_frenet([path.xy[-1, 0]], [path.xy[-1, 1]])
        # the compiled kernels loaded (or, on a first run, compiled) now, not inside the first cycle's timing
        plan(FrenetState(0.0, 1.0, 0.0, 0.0), self.frame, np.zeros((0, len(params.times), 5)), params, road=road)
        self.every, self.periods = round(every), 0
        self.preview = round(PREVIEW / self.params.dt)
        self.tracker = Tracker()
        self.tracks: list[Track] = []
        self.predicted = np.zeros((0, len(params.times), 5))
        """The tracks' boxes the last plan was made among, (futures, times, 5) (:func:`~vilma.perception.predict`)."""
        self.predicted_tracks: list[Track] = []
        """The track of each row of :attr:`predicted` (a track on a lane that forks has one a way)."""
        self.last: tuple[float, Plan] | None = None  # when the driven plan began [s], and the plan
        self.cycles = self.fallbacks = self.evasions = 0
        self.reason: str | None = None
        self.spent_ms = [0.0, 0.0]  # total and longest [ms]
        self.last_ms = math.nan  # the last cycle's [ms]
        if self.kind == "laser":
            self.bearings, self.mount = laser.bearings, (*laser.position[:2], laser.yaw)
            self.segments = SegmentParams(range_noise=laser.range_noise)

    def take(self, msg: Message, pose: PoseEstimate | None) -> bool:
        """Take a scan seen from the estimated ``pose`` (an object list or a laser scan, as the perception is);
        whether it was one (the tracks are then new)."""
        if self.kind == "truth" and isinstance(msg, ObjectList):
            self.tracks = [_track(o) for o in msg.objects]
        elif self.kind == "laser" and isinstance(msg, PointCloud) and pose is not None:
            self.tracks = self.tracker.update(msg.stamp_ns, self._boxes(msg, pose))
        else:
            return False
        return True

    def _boxes(self, scan: PointCloud, pose: PoseEstimate) -> np.ndarray:
        """The boxes (n, 5) of a scan's clusters in the world frame."""
        ranges = np.frombuffer(scan.ranges, "<f4").astype(np.float64)
        clusters = segment(ranges, self.bearings, self.segments)
        return fit_boxes(scan_points(ranges, self.bearings), clusters,
                         laser_pose((pose.x, pose.y, pose.yaw), self.mount))

    def period_done(self, t: float) -> Plan | None:
        """A driver period ended at sim time ``t`` [s]: plan if a replan period is over; the plan, if it planned."""
        self.periods += 1
        return self.cycle(t) if self.periods % self.every == 0 else None

    def cycle(self, t: float) -> Plan | None:
        """Plan at sim time ``t`` [s] from the car's estimated state and hand the plan to the driver; the plan
        (None without an estimate)."""
        est = self.driver.estimator.estimate
        if est is None:
            return None
        t0 = time.perf_counter()
        params = self._targeting(self._speed_ahead(est.x, est.y))
        state, keep = self._start(est, t, params)
        self.predicted_tracks, self.predicted = self._predict(params)
        if any(w.holds(state.s, t, state.s_dot, state.d) for w in self.arrivals):
            self.arrivals = ()  # the goal is reached (once): what is left is the stop at the route's end
        ahead = tuple(dataclasses.replace(w, t=(w.t[0] - t, w.t[1] - t)) for w in self.arrivals if w.t[1] >= t)
        result = plan(state, self.frame, self.predicted, params, goal=self.goal, keep=keep, road=self.road,
                      arrivals=ahead)
        self.last_ms = spent = (time.perf_counter() - t0) * 1e3
        self.spent_ms = [self.spent_ms[0] + spent, max(self.spent_ms[1], spent)]
        self.cycles += 1
        if result.mode in ("fallback", "evasive"):
            self.fallbacks += result.mode == "fallback"
            self.evasions += result.mode == "evasive"
            self.reason = result.reason
        self.last = (t, result)
        path = _previewed(result, self.preview)
        if est.speed < CREEP_SPEED and result.speed[-1] < self.driver.params.rest_speed and _reach(path) < STOP_REACH:
            path = Trajectory(path.xy, np.zeros(len(path)))  # the driver's stop on its end, now
        self.driver.drive_plan(path)
        return result

    def _predict(self, params: PlannerParams) -> tuple[list[Track], np.ndarray]:
        """The tracks' futures at the planner's times (:func:`~vilma.perception.predict`) and the track of each: a
        track moving on a lane (:meth:`~vilma.world.lanes.Lanes.locate`) along each way on from there within its
        reach over the horizon, the others straight on."""
        if self.lanes is None:
            return self.tracks, predict(self.tracks, params.times)
        tracks, lanes, on = [], [], {}
        for track in self.tracks:
            segment = None if track.speed < LANE_SPEED else self.lanes.locate(
                track.x, track.y, math.atan2(track.vy, track.vx), self._on.get(track.id))
            if segment is not None:
                on[track.id] = segment
            ways = (None,) if segment is None else _ways(self.lanes, segment, math.ceil(
                (track.speed * params.horizon + track.length) / LANE_REACH_STEP) * LANE_REACH_STEP)
            tracks += [track] * len(ways)
            lanes += ways
        self._on = on
        return tracks, predict(tracks, params.times, lanes)

    def _targeting(self, speed: float) -> PlannerParams:
        """The planner's parameters with the target ``speed`` [m/s]: made (and checked) again only when it changes,
        which on a road of one speed limit it never does."""
        if self._targeted.target_speed != speed:
            self._targeted = dataclasses.replace(self.params, target_speed=speed)
        return self._targeted

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


@lru_cache(maxsize=256)
def _ways(lanes: Lanes, segment: int, reach: float) -> tuple[Trajectory, ...]:
    """The ways on from ``segment`` of ``lanes`` within ``reach`` [m] (:meth:`~vilma.world.lanes.Lanes.ahead`) as
    trajectories, made once for the tracks on that segment."""
    return tuple(Trajectory(xy) for xy in lanes.ahead(segment, reach))


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
