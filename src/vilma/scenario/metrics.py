"""The scorecard of a run (``metrics.json``): stable keys, SI units, ``None`` where a key does not apply.

Measured on the plant's true motion at every control period (not on what the
driver believed), against the reference path by projection from the centre of
mass. Path and speed-tracking errors are counted after ``MetricsSpec.skip``
seconds. The speed-step keys (rise, overshoot, settling, steady state) apply to
a ``speed`` task, a constant target from the speed the task found the car at (rest
in the paper's Figure 11): :func:`step_response`.

``completed`` says the task was done, judged on the track alone (:func:`completion`):
a speed task when the run lasted without breaking down and the car ended it at the target speed (within
``MetricsSpec.settle_band`` of it, as ``speed_settling_time_2pct_s`` measures); a go-to when the car came
to rest within ``MetricsSpec.end_tolerance`` of the target; a path when, besides,
it covered ``MetricsSpec.min_progress`` of the path in order (:func:`coverage`; not a plan, which leaves its
route to pass); a CommonRoad route when, besides, the car was in the planning problem's goal region (a plan: instead
of coming to rest at the route's end past it) (``goal_reached``, by the goal's own check,
:meth:`~vilma.world.commonroad.EgoTask.goal_time`; ``time_to_goal_s`` from the initial state).
A route is also scored as CommonRoad's benchmark scores it (:mod:`vilma.world.benchmark`): ``collisions``
(how many of the file's obstacles, moving along their recordings or, with ``traffic: reactive``, where IDM
drove them, the car's outline touched), ``off_road``
(touched the road's boundary), ``min_distance_to_traffic_m`` and ``min_time_to_collision_s``; it is complete
only without either (``traffic``: recorded or reactive, ``collisions_checked: true``).
``incomplete_reason`` says why not, in words.

The timing keys (:data:`~vilma.scenario.scorecard.TIMING_KEYS`) are the caller's
(:func:`timing`); ``controller_time_per_step_us`` is the mean wall time of the
driver per period; in the compiled loop, of the whole loop per period (an upper
bound).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vilma.core.geometry import wrap_angle
from vilma.scenario.drive_log import DriveLog
from vilma.scenario.plan_keys import PLANNING_KEYS
from vilma.scenario.spec import SCORECARD_KEYS, Bound, Scenario
from vilma.sim.config import MUJOCO
from vilma.trajectory import Trajectory

WATCHDOG_STOP = "the watchdog stopped the car (the driver sent no command in time)"
"""Why a run whose watchdog tripped did not complete (the runner's and the report's words)."""
ROAD_SCORE_KEYS = ("goal_reached", "time_to_goal_s", "traffic", "collisions_checked", "off_road",
                   "min_time_to_collision_s")
"""The keys only a CommonRoad road's run measures (:func:`_road_checks`)."""
PATH_KEYS = ("end_error_m", "path_progress", "waypoints_skipped", "lateral_error_rms_m", "lateral_error_max_m",
             "lateral_error_p95_m", "heading_error_rms_rad")
"""The keys measured against a path: every task's but a speed task's."""
STEP_KEYS = ("speed_rise_time_90_s", "speed_overshoot_pct", "speed_settling_time_2pct_s",
             "speed_steady_state_error_mps")
"""The keys of a speed step (:func:`step_response`): a speed task's only."""


def scorecard(log: DriveLog, scenario: Scenario, path: Trajectory | None, t_start: float,
              broke_down: str | None = None, truncated: bool = False) -> dict:
    """The scorecard of a drive, without the timing keys; ``t_start`` [s] is when the task began.

    ``broke_down`` is why the run stopped early if the caller knows (a watchdog stop), ``truncated`` that the
    log was cut short (a killed recording); either makes the task incomplete.
    """
    c = log.column
    t, x, y, yaw = c("t"), c("x"), c("y"), c("yaw")
    speed = np.hypot(c("vx"), c("vy")) * np.sign(c("vx"))
    m = scenario.metrics
    counted = t >= t_start + m.skip
    out: dict = dict.fromkeys(SCORECARD_KEYS)
    out.update(truncated=truncated, sim_time_s=float(t[-1]) if len(t) else 0.0,
               distance_m=float(np.sum(np.hypot(np.diff(x), np.diff(y)))))
    finite = np.isfinite(x).all() and np.isfinite(y).all() and np.isfinite(yaw).all()  # a blow-up reaches these
    if not finite:
        broke_down = "the car's state became NaN or infinite"
    elif truncated:
        broke_down = "the recording was cut short"
    xy = np.column_stack([x, y])
    proj = path.project_track(xy) if path is not None else None  # once, for the coverage and the errors
    road_failures = []
    if scenario.road is not None:
        goal = scenario.road.goal_time(t, x, y, yaw, speed)
        out.update(goal_reached=goal is not None, time_to_goal_s=goal)
        if finite:
            road_failures = _road_checks(scenario, log, out)
    elif scenario.sim.model != MUJOCO and finite:
        road_failures = _obstacle_checks(scenario, log, out)
    out.update(completion(scenario, xy, c("vx"), path, broke_down, None if proj is None else proj[:, 0],
                          out["goal_reached"], road_failures))
    if proj is not None and counted.any():
        e = np.abs(proj[counted, 1])
        out.update(lateral_error_rms_m=_rms(e), lateral_error_max_m=float(e.max()),
                   lateral_error_p95_m=float(np.percentile(e, 95)),
                   heading_error_rms_rad=_rms(wrap_angle(yaw[counted] - proj[counted, 2])))
    if counted.any():
        out["speed_error_rms_mps"] = _rms(speed[counted] - c("target_speed")[counted])
    if scenario.task.kind == "speed":
        task_t = t - t_start
        begun = np.flatnonzero(task_t >= 0)  # the step starts from the speed the task found the car at
        out.update(step_response(task_t, speed, scenario.task.speed, m.settle_band, m.steady_window,
                                 float(speed[begun[0]]) if len(begun) else 0.0))
    if len(t) > 2:
        dt = np.diff(t)
        out["steering_rate_rms_radps"] = _rms(np.diff(c("steer")) / dt)
        a_long, a_lat = _accelerations(t, yaw, c("vx"), c("vy"))
        out["lateral_accel_max_mps2"] = float(np.abs(a_lat).max())
        if len(a_long) > 1:
            out["longitudinal_jerk_rms_mps3"] = _rms(np.diff(a_long) / dt[1:])
    if scenario.driver.pose_source != "truth":
        est = ~np.isnan(c("est_x"))
        if est.any():
            out["pose_error_rms_m"] = _rms(np.hypot(c("est_x")[est] - x[est], c("est_y")[est] - y[est]))
    us = c("controller_us")
    if len(us) and not np.isnan(us).all():
        out["controller_time_per_step_us"] = float(np.nanmean(us))
    return {k: plain(v) for k, v in out.items()}


def unmeasured(scenario: Scenario) -> dict[str, str]:
    """The scorecard keys no run of ``scenario`` measures (None whatever the car does), each with why, in words: what
    :func:`scorecard` and the runner (a plan's keys, the 3D plant's collisions) measure depends on these."""
    kind, never = scenario.task.kind, {}
    if scenario.road is None:
        never |= dict.fromkeys(ROAD_SCORE_KEYS, "it has no CommonRoad road")
        if scenario.sim.traffic is None or scenario.sim.model == MUJOCO:
            never["min_distance_to_traffic_m"] = "it has no CommonRoad road, nor boxes or cones on flat ground"
    if kind != "plan":
        never |= dict.fromkeys(PLANNING_KEYS, "it is not a plan task")
    if kind == "speed":
        never |= dict.fromkeys(PATH_KEYS, "a speed task has no path")
    else:
        never |= dict.fromkeys(STEP_KEYS, "only a speed task is a speed step")
    if scenario.driver.pose_source == "truth":
        never["pose_error_rms_m"] = "it steers by the true pose (pose: truth)"
    return never


def _road_checks(scenario: Scenario, log: DriveLog, out: dict) -> list[str]:
    """The benchmark's checks of a CommonRoad drive (:func:`~vilma.world.benchmark.check_drive`, the car's
    outline from its parameters) into ``out``; what they failed, in words."""
    from vilma.world.benchmark import EgoBox, check_drive  # the roads extra, there when the scenario is a road

    car = scenario.sim.vehicle
    c = log.column
    found = check_drive(scenario.road, EgoBox(length=car.length, width=car.width, offset=car.body_offset), c("t"),
                        c("x"), c("y"), c("yaw"), c("vx"), c("vy"))
    out.update(traffic=scenario.traffic, collisions_checked=True, collisions=len(found.hit),
               off_road=found.off_road_time is not None, min_distance_to_traffic_m=found.min_distance,
               min_time_to_collision_s=found.min_time_to_collision)
    why = []
    if found.hit:
        why.append(f"collided with obstacle {', '.join(map(str, found.hit))} (first at {found.collision_time:.3g} s)")
    if found.off_road_time is not None:
        why.append(f"left the road at {found.off_road_time:.3g} s")
    return why


def _obstacle_checks(scenario: Scenario, log: DriveLog, out: dict) -> list[str]:
    """``collisions`` (how many of a flat world's boxes and cones, standing still, the car's outline touched) and
    ``min_distance_to_traffic_m`` (None without them) of a drive on flat ground, at each logged pose, into ``out``;
    the collisions in words."""
    traffic, car, c = scenario.sim.traffic, scenario.sim.vehicle, log.column
    if traffic is None or not len(c("t")):
        out["collisions"] = 0
        return []
    yaw = c("yaw")
    heading = np.column_stack([np.cos(yaw), np.sin(yaw)])[:, None, :]
    centre = np.column_stack([c("x"), c("y")])[:, None, :] + car.body_offset * heading
    corners = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)]) * (car.length / 2, car.width / 2)
    normal = heading[..., ::-1] * (-1, 1)
    body = centre + corners[None, :, :1] * heading + corners[None, :, 1:] * normal  # (n, 4, 2)
    obstacles, _ = traffic.polygons(np.zeros(1, np.int64))  # standing still: as at time step 0, (1, m, p, 2)
    gap = convex_gap(body[:, None], obstacles)  # (n, m)
    hit = (gap <= 0).any(axis=0)
    out.update(collisions=int(hit.sum()), min_distance_to_traffic_m=float(gap.min()))
    if not hit.any():
        return []
    names = np.array(scenario.sim.world.obstacle_names())
    first = float(c("t")[np.flatnonzero((gap <= 0).any(axis=1))[0]])
    return [f"collided with {', '.join(names[hit])} (first at {first:.3g} s)"]


def convex_gap(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The gap [m] between convex polygons ``a`` (..., i, 2) and ``b`` (..., j, 2) (vertices in order, broadcast
    over the leading axes), 0 where they overlap or touch: no separating axis among their edge normals, else the
    nearest vertex of one to an edge of the other."""
    separated = np.zeros(np.broadcast_shapes(a.shape[:-2], b.shape[:-2]), bool)
    for poly in (a, b):
        edge = np.roll(poly, -1, axis=-2) - poly
        axes = np.stack([-edge[..., 1], edge[..., 0]], axis=-1)  # a repeated vertex's is zero: separates nothing
        pa, pb = np.einsum("...ki,...ji->...kj", axes, a), np.einsum("...ki,...ji->...kj", axes, b)
        separated |= ((pa.max(-1) < pb.min(-1)) | (pb.max(-1) < pa.min(-1))).any(-1)
    return np.where(separated, np.minimum(_vertex_to_edges(a, b), _vertex_to_edges(b, a)), 0.0)


def _vertex_to_edges(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """The least distance [m] from ``points`` (..., i, 2) to the edges of the polygon ``poly`` (..., j, 2)."""
    p, v = points[..., :, None, :], poly[..., None, :, :]
    d = np.roll(poly, -1, axis=-2)[..., None, :, :] - v
    t = np.clip(np.sum((p - v) * d, -1) / np.maximum(np.sum(d * d, -1), 1e-12), 0.0, 1.0)
    return np.hypot(*np.moveaxis(p - v - t[..., None] * d, -1, 0)).min(axis=(-2, -1))


def timing(sim_time: float, wall: float, loop: float | None, load: float | None) -> dict:
    """The wall-clock keys: ``wall`` [s] the whole command's share, ``loop`` [s] the closed loop's own time
    (``realtime_factor`` is sim time over it), ``load`` [s] the one-off loading of compiled code."""
    factor = sim_time / loop if loop else None
    return {k: plain(v) for k, v in (("wall_time_s", wall), ("loop_wall_time_s", loop), ("load_time_s", load),
                                      ("realtime_factor", factor))}


def completion(scenario: Scenario, xy: np.ndarray, vx: np.ndarray, path: Trajectory | None,
               broke_down: str | None = None, s: np.ndarray | None = None, goal_reached: bool | None = None,
               road_failures: Sequence[str] = ()) -> dict:
    """``completed``, ``incomplete_reason``, ``end_error_m``, ``path_progress`` and ``waypoints_skipped`` of a
    drive ``xy`` (n, 2) [m] at longitudinal speed ``vx`` (n,) [m/s] on the task's ``path`` (for a go-to, the
    line to the target); at rest means below the driver's ``rest_speed``, as the driver and the runner judge. A
    speed task is done when it ends at its speed, within ``MetricsSpec.settle_band`` of it.
    ``s`` is the drive's arc length projected on the path, if the caller has it (:func:`coverage`);
    ``goal_reached`` False (a route that missed its goal region) and ``road_failures`` (collisions, leaving the
    road, in words) make it incomplete."""
    m, kind = scenario.metrics, scenario.task.kind
    out: dict = {}
    why = [broke_down] if broke_down else []
    if not len(xy):
        why.append("the run has no samples")
    elif kind == "speed":  # holding the speed: at it, within the settling band, when the run ended
        target = scenario.task.speed
        if abs(vx[-1] - target) > m.settle_band * target:
            why.append(f"ended at {vx[-1]:.3g} m/s, not within {m.settle_band:.0%} of the {target:g} m/s target")
    elif path is not None:
        end = float(np.hypot(*(xy[-1] - path.xy[-1])))
        out["end_error_m"] = end
        covered, reached = coverage(path, xy, m.path_tolerance, s)
        out["path_progress"] = covered / path.length if path.length > 0 else 1.0
        out["waypoints_skipped"] = int(len(reached) - reached.sum())
        target = "target" if kind == "go_to" else "end of the path"
        if kind not in ("go_to", "plan") and out["path_progress"] < m.min_progress:
            why.append(f"covered {out['path_progress']:.0%} of the path within {m.path_tolerance:g} m "
                       f"(needs {m.min_progress:.0%}), skipping {out['waypoints_skipped']} of {len(reached)} "
                       "waypoints")
        if kind == "plan" and goal_reached is not None:
            pass  # a planning problem's goal region judges the plan, not the route's end past it
        elif end > m.end_tolerance:
            why.append(f"ended {end:.3g} m from the {target} (tolerance {m.end_tolerance:g} m)")
        elif abs(vx[-1]) >= scenario.driver.rest_speed:
            why.append(f"still moving at {abs(vx[-1]):.3g} m/s at the {target} when the run ended")
    if goal_reached is False:
        why.append("never in the planning problem's goal region (its position, orientation, speed and time "
                   "intervals)")
    why.extend(road_failures)
    out.update(completed=not why, incomplete_reason="; ".join(why) or None)
    return out


def coverage(path: Trajectory, xy: np.ndarray, tolerance: float,
             s: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """How much of ``path`` the drive ``xy`` (n, 2) [m] covered in order: (arc length [m], reached (len(path),)).

    The drive is projected in order (:meth:`~vilma.trajectory.Trajectory.project_track`); each step between
    two samples within ``tolerance`` [m] of their projections that moves forward along the path, by no more
    than the distance driven plus twice the tolerance, covers the arc between the projections, widened by
    the tolerance at both ends. A waypoint is reached when its arc length is covered. ``s`` [m], (n,): the
    projections' arc lengths, if already made.
    """
    if s is None:
        s = path.project_track(xy)[:, 0]
    near = np.hypot(xy[:, 0] - np.interp(s, path.s, path.xy[:, 0]),
                    xy[:, 1] - np.interp(s, path.s, path.xy[:, 1])) <= tolerance
    ds, moved = np.diff(s), np.hypot(*np.diff(xy, axis=0).T)
    step = near[:-1] & near[1:] & (ds >= 0) & (ds <= moved + 2 * tolerance)
    lo = np.clip(s[:-1][step] - tolerance, 0.0, path.length)
    hi = np.clip(s[1:][step] + tolerance, 0.0, path.length)
    lo, hi = _union(lo, hi)
    i = np.searchsorted(lo, path.s, side="right") - 1
    reached = (i >= 0) & (path.s <= hi[np.maximum(i, 0)]) if len(lo) else np.zeros(len(path), bool)
    return float(np.sum(hi - lo)), reached


def _union(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The union of the intervals ``[lo, hi]`` as sorted disjoint intervals."""
    if not len(lo):
        return lo, hi
    order = np.argsort(lo, kind="stable")
    lo, hi = lo[order], np.maximum.accumulate(hi[order])
    start = np.concatenate([[True], lo[1:] > hi[:-1]])  # a gap before this interval
    first = np.flatnonzero(start)
    last = np.concatenate([first[1:] - 1, [len(lo) - 1]])
    return lo[first], hi[last]


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def plain(v):
    """JSON-ready: NaN and infinity become None (a key that cannot be measured), numpy scalars floats."""
    if isinstance(v, bool | str) or v is None:
        return v
    if isinstance(v, int | np.integer):
        return int(v)
    v = float(v)
    return v if math.isfinite(v) else None


def _accelerations(t, yaw, vx, vy) -> tuple[np.ndarray, np.ndarray]:
    """Longitudinal and lateral acceleration [m/s^2] between samples, from the world-frame velocity."""
    c, s = np.cos(yaw), np.sin(yaw)
    wx, wy = vx * c - vy * s, vx * s + vy * c
    dt = np.diff(t)
    ax, ay = np.diff(wx) / dt, np.diff(wy) / dt
    mid = yaw[:-1] + 0.5 * wrap_angle(np.diff(yaw))
    cm, sm = np.cos(mid), np.sin(mid)
    return ax * cm + ay * sm, -ax * sm + ay * cm


def step_response(t: np.ndarray, v: np.ndarray, target: float, band: float, window: float,
                  start: float = 0.0) -> dict:
    """Rise time to 90 %, overshoot, settling time into +-``band`` and steady-state error of a speed step from
    ``start`` to ``target`` [m/s] at t = 0 [s].

    The rise time is when the speed first covered 90 % of the step (``start + 0.9 (target - start)``), the
    overshoot how far it went past the target, in % of the step; a start already within the band of the target
    is no step, and has neither. Settling (into ``band`` x ``target``) and the steady-state error (the mean
    over the last ``window`` [s]) are the target's alone.
    """
    after = t >= 0
    t, v = t[after], v[after]
    out = {}
    step = target - start
    if len(v) and abs(step) > band * target:  # forward, along the step: a step down counts as one up
        u = (v - start) / step  # the fraction of the step covered
        reached = np.nonzero(u >= 0.9)[0]
        if len(reached):
            i = reached[0]
            out["speed_rise_time_90_s"] = float(t[i] if i == 0 else np.interp(0.9, [u[i - 1], u[i]], [t[i - 1], t[i]]))
        out["speed_overshoot_pct"] = float(max(0.0, (u.max() - 1.0) * 100.0))
    outside = np.nonzero(np.abs(v - target) > band * target)[0]
    if len(v) and (not len(outside) or outside[-1] < len(v) - 1):
        out["speed_settling_time_2pct_s"] = float(t[outside[-1] + 1]) if len(outside) else float(t[0])
    tail = t >= t[-1] - window if len(t) else after
    if len(t):
        out["speed_steady_state_error_mps"] = float(abs(np.mean(v[tail]) - target))
    return out


def expectation_failures(metrics: dict, scenario: Scenario) -> list[str]:
    """What a run's scorecard fails of its scenario's ``expect`` (completion unless it says
    ``completed: false``), one line each; an incomplete task says why."""
    failed = check_expectations(metrics, {"completed": True, **scenario.expect})
    return [f"completed: no, {metrics['incomplete_reason']}" if f.startswith("completed:") else f for f in failed]


def check_expectations(metrics: dict, expect: dict[str, Bound | bool]) -> list[str]:
    """The pass criteria a scorecard fails, one line each (empty: it passes)."""
    failed = []
    for key, want in expect.items():
        got = metrics.get(key)
        if isinstance(want, bool):
            if got is not want:
                failed.append(f"{key}: expected {str(want).lower()}, got {got}")
        elif not want.check(got):
            lims = " and ".join(f"{n} {v:g}" for n, v in (("min", want.min), ("max", want.max)) if v is not None)
            failed.append(f"{key}: {got if got is None else f'{got:.4g}'} is outside {lims}")
    return failed
