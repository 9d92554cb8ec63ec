"""The local motion planner: sampled Frenet-frame polynomials, Werling et al. 2010.

M. Werling, J. Ziegler, S. Kammel, S. Thrun, "Optimal trajectory generation for dynamic street scenarios in a
Frenet frame", ICRA 2010. Each cycle samples lateral quintics ``d(t)`` to lane offsets and longitudinal
polynomials ``s(t)`` (quartics for velocity keeping; quintics to a point for following a lead, Werling's
``s_target = s_lead - (d0 + tau v_lead)``, and for stopping at the goal), each lateral end offset with the
longitudinal ones for the lead in that lane, rejects the infeasible (curvature beyond the car's steering,
acceleration or lateral acceleration beyond its limits, driving backwards, the car's box across the road's edges)
and those whose car box overlaps a predicted object's box at the same time (separating axes), and keeps the
cheapest of the rest. When none is left the plan is the safe fallback: a stop at the car's
comfortable deceleration, or at its emergency deceleration when that one collides, with the reason. When even that
one collides, an evasive manoeuvre is sought first: finer end offsets, the tyres' grip for a limit and the bare boxes
(no margin), since a swerve at the limit of grip is the lesser harm than a collision. A planning failure is never an
exception; only malformed parameters or inputs raise ValueError.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import IntEnum
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numba import njit

from vilma.planning.frenet import FrenetFrame, FrenetState, frame_pose, frenet_motion
from vilma.planning.params import PlannerParams
from vilma.planning.polynomials import evaluate, jerk_cost, quartic, quintic
from vilma.trajectory import Arrival, Trajectory

SLOWDOWN_HORIZONS = 100
"""The steady slow-down to a target is planned over at most this many horizons: longer, it keeps the speed over
the horizon all but exactly (and its polynomial would overflow)."""


class Status(IntEnum):
    """What became of a candidate."""

    FEASIBLE = 0
    """Within the car's limits and free of every predicted object."""
    INFEASIBLE = 1
    COLLIDING = 2


class Candidates(NamedTuple):
    """The candidates of a cycle, for drawing: paths (n, n_t) [m], :class:`Status` (n,) and costs (n,)."""

    x: np.ndarray
    y: np.ndarray
    status: np.ndarray
    cost: np.ndarray


@dataclass(frozen=True, slots=True)
class Plan:
    """A planning cycle's result: the trajectory to drive (arrays (n_t,) over ``t`` [s] from the cycle's state).

    Attributes:
        t: times [s]; x, y: the car's reference point [m]; yaw [rad]; speed [m/s]; accel: tangential [m/s^2];
        curvature [1/m]; frenet: (n_t, 6) s, s_dot, s_ddot, d, d_dot, d_ddot (:class:`FrenetState` fields).
        cost: of the chosen candidate (inf for the fallback). mode: ``velocity``, ``follow``, ``stop`` or
        ``fallback``. candidates: every candidate evaluated. reason: why the plan is the fallback ('' if not).
        lateral: the chosen lateral motion's end offset [m] and duration [s], for the next cycle to continue it
            (``keep`` of :func:`plan`); None for the fallback.
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray
    accel: np.ndarray
    curvature: np.ndarray
    frenet: np.ndarray
    cost: float
    mode: str
    candidates: Candidates
    reason: str = ""
    lateral: tuple[float, float] | None = None

    def state_at(self, time: float) -> FrenetState:
        """The plan's Frenet state at ``time`` [s] after its start (the nearest step): where the next cycle starts
        when the car follows the plan."""
        k = min(max(round(time / (self.t[1] - self.t[0])), 0), len(self.t) - 1)
        return FrenetState(*(float(v) for v in self.frenet[k]))

    @property
    def trajectory(self) -> Trajectory:
        """The plan as a trajectory with speeds, for the path and speed controllers."""
        return Trajectory(np.column_stack([self.x, self.y]), self.speed)


class RoadBounds(NamedTuple):
    """The road's edges along a reference path: at arc lengths ``s`` (m,) [m], the offsets of its ``left`` and
    ``right`` edges (m,) [m] (left positive; -inf, inf where unbounded). A candidate whose car box crosses them is
    infeasible."""

    s: np.ndarray
    left: np.ndarray
    right: np.ndarray


NO_ROAD = RoadBounds(np.zeros(0), np.zeros(0), np.zeros(0))


class _Car(NamedTuple):
    half_length: float
    half_width: float
    offset: float
    max_curvature: float
    max_accel: float
    max_decel: float
    max_lateral_accel: float


@njit(cache=True)
def boxes_overlap(ax, ay, ayaw, ahl, ahw, bx, by, byaw, bhl, bhw):
    """Whether two oriented boxes (centre, yaw, half length, half width) overlap: no separating axis among their
    four edge normals (touching counts as overlap)."""
    dx, dy = bx - ax, by - ay
    ca, sa, cb, sb = math.cos(ayaw), math.sin(ayaw), math.cos(byaw), math.sin(byaw)
    for ux, uy in ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb)):
        ra = ahl * abs(ca * ux + sa * uy) + ahw * abs(-sa * ux + ca * uy)
        rb = bhl * abs(cb * ux + sb * uy) + bhw * abs(-sb * ux + cb * uy)
        if abs(dx * ux + dy * uy) > ra + rb:
            return False
    return True


@njit(cache=True)
def _collides(car, x, y, yaw, objects, k, near, margin):
    """Whether the car at ``(x, y, yaw)`` overlaps any of the ``near`` object boxes at step ``k``."""
    hl, hw = car.half_length + margin, car.half_width + margin
    cx, cy = x + car.offset * math.cos(yaw), y + car.offset * math.sin(yaw)
    r = math.hypot(hl, hw)
    for o in range(objects.shape[0]):
        if not near[o, k]:
            continue
        ox, oy, oyaw, ol, ow = objects[o, k, 0], objects[o, k, 1], objects[o, k, 2], objects[o, k, 3], objects[o, k, 4]
        reach = r + 0.5 * math.hypot(ol, ow)
        if (ox - cx) ** 2 + (oy - cy) ** 2 > reach * reach:
            continue  # the bounding circles are apart
        if boxes_overlap(cx, cy, yaw, hl, hw, ox, oy, oyaw, 0.5 * ol, 0.5 * ow):
            return True
    return False


@njit(cache=True)
def _near(objects, out, checked, reach):
    """(n_obj, n_t): whether an object's bounding circle at a step comes within ``reach`` [m] of the box around
    the points of the ``checked`` candidates at that step (the others cannot touch any of them)."""
    n_obj, n_t = objects.shape[0], objects.shape[1]
    near = np.zeros((n_obj, n_t), dtype=np.bool_)
    for k in range(n_t):
        lo_x, hi_x, lo_y, hi_y = np.inf, -np.inf, np.inf, -np.inf
        for c in range(checked.shape[0]):
            if checked[c]:
                lo_x, hi_x = min(lo_x, out[0, c, k]), max(hi_x, out[0, c, k])
                lo_y, hi_y = min(lo_y, out[1, c, k]), max(hi_y, out[1, c, k])
        for o in range(n_obj):
            r = reach + 0.5 * math.hypot(objects[o, k, 3], objects[o, k, 4])
            near[o, k] = lo_x - r <= objects[o, k, 0] <= hi_x + r and lo_y - r <= objects[o, k, 1] <= hi_y + r
    return near


@njit(cache=True)
def _combine(fa, lat, lon, edges, objects, car, margin, check_all, out, status):
    """Every lateral (3, n_lat, n_t) with every longitudinal (3, n_lon, n_t) motion: Cartesian motion into
    ``out`` (6, n_lat * n_lon, n_t: x, y, yaw, speed, accel, curvature) and the :class:`Status` of each
    (the infeasible checked for collisions too with ``check_all``); off the road's left and right ``edges``
    (2, n_lon, n_t) [m] where each longitudinal motion is (or (2, 0, 0): unbounded) is infeasible."""
    n_lat, n_lon, n_t = lat.shape[1], lon.shape[1], lat.shape[2]
    bounded = edges.shape[1] > 0
    # the reference's pose (x, y, theta, k, dk) and its heading's sine and cosine where each longitudinal motion
    # is at each step: shared by every lateral one
    ref = np.empty((n_lon, n_t, 7))
    for j in range(n_lon):
        for k in range(n_t):
            x, y, theta, kr, dk = frame_pose(fa, lon[0, j, k])
            ref[j, k, 0], ref[j, k, 1], ref[j, k, 2], ref[j, k, 3], ref[j, k, 4] = x, y, theta, kr, dk
            ref[j, k, 5], ref[j, k, 6] = math.sin(theta), math.cos(theta)
    for i in range(n_lat):
        for j in range(n_lon):
            c = i * n_lon + j
            ok = True
            for k in range(n_t):
                theta, kr, dk = ref[j, k, 2], ref[j, k, 3], ref[j, k, 4]
                d = lat[0, i, k]
                s_dot = lon[1, j, k]
                yaw, v, a, kappa = frenet_motion(theta, kr, dk, s_dot, lon[2, j, k], d, lat[1, i, k], lat[2, i, k])
                out[0, c, k] = ref[j, k, 0] - d * ref[j, k, 5]
                out[1, c, k] = ref[j, k, 1] + d * ref[j, k, 6]
                out[2, c, k], out[3, c, k], out[4, c, k], out[5, c, k] = yaw, v, a, kappa
                if (s_dot < -1e-6 or 1.0 - kr * d <= 0.0 or abs(kappa) > car.max_curvature
                        or a > car.max_accel or a < -car.max_decel or abs(kappa) * v * v > car.max_lateral_accel):
                    ok = False
                elif bounded:  # the box's extent across the reference, against the road's edges
                    phi = yaw - theta
                    centre = d + car.offset * math.sin(phi)
                    half = (car.half_width + margin) * abs(math.cos(phi)) + (car.half_length + margin) * abs(
                        math.sin(phi))
                    if centre + half > edges[0, j, k] or centre - half < edges[1, j, k]:
                        ok = False
            status[c] = 0 if ok else 1
    checked = (status == 0) | check_all
    near = _near(objects, out, checked, abs(car.offset) + math.hypot(car.half_length + margin, car.half_width + margin))
    close = np.zeros(n_t, dtype=np.bool_)  # the steps some object is near at: the others need no check (most)
    for k in range(n_t):
        for o in range(near.shape[0]):
            close[k] |= near[o, k]
    for c in range(status.shape[0]):
        if checked[c]:
            for k in range(n_t):
                if close[k] and _collides(car, out[0, c, k], out[1, c, k], out[2, c, k], objects, k, near, margin):
                    status[c] = 2
                    break


def _car(p: PlannerParams) -> _Car:
    v = p.vehicle
    return _Car(0.5 * v.length, 0.5 * v.width, v.body_offset, p.max_curvature, v.actuators.max_accel,
                v.actuators.max_decel, p.max_lateral_accel)


class _Target(NamedTuple):
    """A point to reach: at ``s + speed t`` [m] at time t, moving at ``speed`` [m/s]."""

    mode: str
    s: float
    speed: float


def _lead_target(state: FrenetState, s: np.ndarray, d: np.ndarray, objects: np.ndarray, lane: float,
                 p: PlannerParams) -> _Target | None:
    """Werling's following target behind the nearest object ahead within half a lane of the offset ``lane`` [m];
    ``s``, ``d`` (n_obj, 2): the objects' Frenet coordinates now and a step later."""
    ahead = (np.abs(d[:, 0] - lane) < 0.5 * p.lane_width) & (s[:, 0] > state.s)
    if not ahead.any():
        return None
    i = np.flatnonzero(ahead)[np.argmin(s[ahead, 0])]
    speed = max((s[i, 1] - s[i, 0]) / p.dt, 0.0)
    front = p.vehicle.body_offset + 0.5 * p.vehicle.length  # the car's front bumper ahead of its reference point
    gap = p.follow_distance + p.time_gap * speed
    return _Target("follow", float(s[i, 0] - 0.5 * objects[i, 0, 3] - front - gap), float(speed))


def _binds(target: _Target, state: FrenetState, p: PlannerParams) -> bool:
    """Whether a target is near enough to plan for: the car, keeping the faster of its speed and the target
    speed over the horizon, would close on it by more than its distance (then it brakes at half the comfortable
    deceleration to the target's speed)."""
    v = max(state.s_dot, p.target_speed)
    closing = max(v - target.speed, 0.0) * p.horizon + max(v * v - target.speed**2, 0.0) / (
        p.vehicle.actuators.stop_deceleration)
    return target.s - state.s <= closing


def _longitudinal(state: FrenetState, target: _Target | None, p: PlannerParams):
    """Longitudinal polynomials (n, 6), their durations (n,) and costs (n,)."""
    if target is None:
        T = np.repeat(np.asarray(p.speed_durations), len(p.speed_offsets))
        want = np.tile(p.target_speed + np.asarray(p.speed_offsets), len(p.speed_durations))
        reach = np.clip(want, state.s_dot - p.vehicle.actuators.stop_deceleration * T,
                        state.s_dot + p.comfort_accel * T)
        # and for each duration a hard slow-down, to swerve and brake at once (a quartic from and to no acceleration
        # peaks at 1.5 times its mean: 1.5 x 0.6 = 90 % of the car's deceleration)
        T = np.append(T, p.speed_durations)
        reach = np.append(reach, state.s_dot - 0.6 * p.vehicle.actuators.max_decel * np.asarray(p.speed_durations))
        v1 = np.maximum(reach, 0.0)
        coeffs = quartic(state.s, state.s_dot, state.s_ddot, v1, 0.0, T)
        miss = p.speed_weight * (v1 - p.target_speed) ** 2
    else:
        durations = list(p.position_durations)
        closing = state.s_dot - target.speed
        if closing > 0 and target.s > state.s:  # and the time a steady slow-down to the target speed closes the gap in
            # (at most SLOWDOWN_HORIZONS horizons: closing at a crawl it would overflow the polynomials, or itself)
            gap, longest = target.s - state.s, SLOWDOWN_HORIZONS * p.horizon
            durations.append(max(2.0 * gap / closing, p.dt) if 2.0 * gap < closing * longest else longest)
        T = np.repeat(np.asarray(durations), len(p.position_offsets))
        dev = np.tile(np.asarray(p.position_offsets), len(durations))
        v0, v1, b = state.s_dot, target.speed, p.vehicle.actuators.stop_deceleration
        end = target.s + v1 * T + dev
        if v0 > v1:  # an end the car reaches only braking harder than comfortably moves on to where it does
            end = np.maximum(end, state.s + (v0 * v0 - v1 * v1) / (2.0 * b) + v1 * np.maximum(T - (v0 - v1) / b, 0))
        coeffs = quintic(state.s, state.s_dot, state.s_ddot, end, v1, 0.0, T)
        miss = p.position_weight * (end - target.s - v1 * T) ** 2
        if target.mode == "follow":  # the speed given up behind a slower lead, so that passing it competes
            miss = miss + p.speed_weight * max(p.target_speed - v1, 0.0) ** 2
    return coeffs, T, p.jerk_weight * jerk_cost(coeffs, T) + p.time_weight * T + miss


def _lateral(state: FrenetState, offsets: list[float], p: PlannerParams, keep: tuple[float, float] | None):
    """Lateral quintics (n, 6) to the end ``offsets`` [m], their durations (n,), costs (n,) and end offsets (n,);
    and ``keep`` (end offset [m], duration [s]) if its offset is among them. Made once for the cycles that start
    alike (a car keeping its lane starts each at no offset), copied."""
    start = np.array(state[3:]).tobytes()  # d, d_dot, d_ddot by their bits: the sign of a zero carries on
    made = _lateral_from(start, tuple(offsets), p.lateral_durations, (p.jerk_weight, p.time_weight, p.offset_weight),
                         keep)
    return tuple(a.copy() for a in made)


@lru_cache(maxsize=64)
def _lateral_from(start: bytes, offsets: tuple[float, ...], durations: tuple[float, ...],
                  weights: tuple[float, float, float], keep: tuple[float, float] | None):
    """:func:`_lateral` from the lateral state ``start`` (d, d_dot, d_ddot as float64 bytes) with the ``weights``
    of jerk, time and offset."""
    T = np.repeat(np.asarray(durations), len(offsets))
    d1 = np.tile(np.asarray(offsets), len(durations))
    if keep is not None and keep[0] in offsets:
        T, d1 = np.append(T, keep[1]), np.append(d1, keep[0])
    coeffs = quintic(*np.frombuffer(start), d1, 0.0, 0.0, T)
    return coeffs, T, weights[0] * jerk_cost(coeffs, T) + weights[1] * T + weights[2] * d1**2, d1


def _motions(frame, lat, lat_T, lon, lon_T, objects, p, road=NO_ROAD, check_all=False):
    t = p.times
    lat_m, lon_m = evaluate(lat, lat_T, t)[:3], evaluate(lon, lon_T, t)[:3]
    n = lat_m.shape[1] * lon_m.shape[1]
    out, status = np.empty((6, n, len(t))), np.empty(n, dtype=np.int8)
    edges = (np.stack([np.interp(lon_m[0], road.s, road.left), np.interp(lon_m[0], road.s, road.right)])
             if len(road.s) else np.empty((2, 0, 0)))
    _combine(frame.arrays, lat_m, lon_m, edges, objects, _car(p), p.margin, check_all, out, status)
    return lat_m, lon_m, out, status


def _check(state: FrenetState, objects: np.ndarray, p: PlannerParams) -> np.ndarray:
    if not all(math.isfinite(v) for v in state):
        raise ValueError(f"plan: the car's Frenet state must be finite numbers, got {tuple(state)}")
    objects = np.ascontiguousarray(objects, dtype=np.float64)
    if objects.ndim != 3 or objects.shape[1:] != (p.steps + 1, 5):
        raise ValueError(f"plan: predicted objects must be an array (n_obj, {p.steps + 1}, 5) of x, y, yaw, "
                         f"length, width at the planner's times, got shape {objects.shape}")
    if not np.isfinite(objects).all():
        raise ValueError("plan: predicted objects must be finite numbers")
    return objects


def plan(state: FrenetState, reference: FrenetFrame, objects, params: PlannerParams,
         goal: float | None = None, keep: tuple[float, float] | None = None, road: RoadBounds = NO_ROAD,
         arrivals: tuple[Arrival, ...] = ()) -> Plan:
    """Plan from the car's ``state`` along ``reference`` among predicted ``objects`` (n_obj, n_t, 5: x, y [m],
    yaw [rad], length, width [m] at ``params.times``), stopping at arc length ``goal`` [m] if given, within the
    ``road``'s edges if given.

    ``arrivals`` are a goal region's windows (along ``reference``, times from now): while some free candidate is
    in one of them within the horizon, the cheapest of those is the plan (a CommonRoad goal is reached in its time
    window, which no cost sees).

    ``keep``, a lateral motion's end offset [m] (one of the planner's) and the time left to it [s], is the lane
    change under way, sampled besides the lateral durations (Werling's consistent replanning). One leading away
    from the reference (a pass) is chosen while any of its candidates is free, so that it is finished unless it
    would collide: started over each cycle, its end would be ever a whole duration away, and the car would creep
    across while each plan is checked as a swift one.

    Each lateral end offset has its longitudinal mode: following the nearest object ahead within half a lane of
    that offset, or stopping at the goal, whichever target is nearer, once the car keeping its speed would come
    within its braking distance of it over the horizon; velocity keeping otherwise. So a lane change past a
    slower or stopped lead keeps its speed, and competes with following the lead by the speed that gives up. The
    lateral motion is planned in time (Werling's high-speed mode), so that at walking pace a lane change comes
    out infeasible by its curvature.
    """
    objects = _check(state, objects, params)
    found, candidates = _search(state, reference, objects, params, goal, keep, road, arrivals)
    if found is not None:
        return found
    stop, collides = _fallback(state, reference, objects, params, candidates)
    if collides and params.evasive_grip > 0:
        evasive = params.evasive
        found, _ = _search(state, reference, objects, evasive, goal, keep, road, arrivals)
        if found is not None:
            return replace(found, mode="evasive", reason=f"{stop.reason}: swerving instead, at up to "
                                                         f"{evasive.max_lateral_accel:.1f} m/s^2 across")
    return stop


def _search(state: FrenetState, reference: FrenetFrame, objects: np.ndarray, params: PlannerParams,
            goal: float | None, keep: tuple[float, float] | None, road: RoadBounds,
            arrivals: tuple[Arrival, ...]) -> tuple[Plan | None, Candidates]:
    """The cheapest free candidate's plan (None if none is free) and every candidate (:func:`plan`)."""
    stop = None if goal is None else _Target("stop", float(goal), 0.0)
    s, d = reference.to_frenet(objects[:, :2, 0], objects[:, :2, 1]) if len(objects) else (None, None)
    lanes: dict[_Target | None, list[float]] = {}  # each target, and the end offsets that plan for it
    kept = []  # the candidates of the lateral motion to keep, in each group
    for lane in dict.fromkeys(params.lateral_offsets):
        lead = None if s is None else _lead_target(state, s, d, objects, lane, params)
        targets = [t for t in (lead, stop) if t is not None and _binds(t, state, params)]
        lanes.setdefault(min(targets, key=lambda t: t.s + t.speed * params.horizon, default=None), []).append(lane)
    groups = []
    for target, offsets in lanes.items():
        lat, lat_T, lat_cost, lat_end = _lateral(state, offsets, params, keep)
        lon, lon_T, lon_cost = _longitudinal(state, target, params)
        lat_m, lon_m, out, status = _motions(reference, lat, lat_T, lon, lon_T, objects, params, road)
        lat_cost = lat_cost + params.deviation_weight * (lat_m[0] ** 2).mean(axis=1)
        cost = (params.lateral_weight * lat_cost[:, None] + params.longitudinal_weight * lon_cost[None, :]).ravel()
        groups.append((target, lat_m, lon_m, out, status, cost, np.column_stack([lat_end, lat_T])))
        kept.append(np.zeros((len(lat_T), len(lon_T)), bool))
        kept[-1][-1] = keep is not None and keep[0] in offsets  # (_lateral appends it)
    out, status, cost = (np.concatenate([g[k] for g in groups], axis=1 if k == 3 else 0) for k in (3, 4, 5))
    candidates = Candidates(out[0], out[1], status, cost)
    free = np.flatnonzero(status == Status.FEASIBLE)
    kept = np.concatenate([k.ravel() for k in kept])[free]
    if kept.any() and abs(keep[0]) > abs(state.d):
        free = free[kept]
    if arrivals and len(free):
        arrive = np.concatenate([_arriving(g[1], g[2], arrivals, params.times).ravel() for g in groups])[free]
        if arrive.any():
            free = free[arrive]
    if len(free) == 0:
        return None, candidates
    chosen = int(free[np.argmin(cost[free])])
    starts = np.cumsum([0] + [len(g[4]) for g in groups])
    g = int(np.searchsorted(starts, chosen, "right")) - 1
    (target, lat_m, lon_m), lateral = groups[g][:3], groups[g][6]
    i, j = divmod(chosen - int(starts[g]), lon_m.shape[1])
    frenet = np.column_stack([lon_m[0, j], lon_m[1, j], lon_m[2, j], lat_m[0, i], lat_m[1, i], lat_m[2, i]])
    return Plan(params.times, *out[:, chosen], frenet, float(cost[chosen]),
                "velocity" if target is None else target.mode, candidates,
                lateral=(float(lateral[i, 0]), float(lateral[i, 1]))), candidates


def _arriving(lat_m: np.ndarray, lon_m: np.ndarray, arrivals: tuple[Arrival, ...], t: np.ndarray) -> np.ndarray:
    """Whether each pair of lateral and longitudinal motions (3, n, n_t: position, rate, acceleration) is in one of
    the ``arrivals`` at one of the times ``t`` [s] (n_lat, n_lon)."""
    s, v, d = lon_m[0], lon_m[1], lat_m[0]
    out = np.zeros((d.shape[0], s.shape[0]), bool)
    for w in arrivals:
        on = ((t >= w.t[0]) & (t <= w.t[1]))[None] & (s >= w.s[0]) & (s <= w.s[1]) & (v >= w.v[0]) & (v <= w.v[1])
        if not on.any():
            continue
        if w.d:
            arc, lo, hi = np.asarray(w.d).T
            on = on[None] & (d[:, None] >= np.interp(s, arc, lo)[None]) & (d[:, None] <= np.interp(s, arc, hi)[None])
        out |= on.any(axis=-1)
    return out


def _fallback(state: FrenetState, reference: FrenetFrame, objects: np.ndarray, p: PlannerParams,
              candidates: Candidates) -> tuple[Plan, bool]:
    """The safe stop: along the reference at the comfortable deceleration (the car's controlled stop), or its
    emergency deceleration when the comfortable stop collides; the lane offset settles where it is. And whether
    it still collides."""
    infeasible = int((candidates.status == Status.INFEASIBLE).sum())
    why = f"no free candidate: {infeasible} infeasible, {len(candidates.status) - infeasible} colliding"
    lat = quintic(state.d, state.d_dot, state.d_ddot, state.d, 0.0, 0.0, min(p.lateral_durations))[None]
    v0 = max(state.s_dot, 0.0)

    def stop(decel):
        lon = np.array([[state.s, v0, -0.5 * decel if v0 > 0 else 0.0, 0.0, 0.0, 0.0]])
        stopped = v0 / decel if v0 > 0 else p.dt  # at rest from then on (a longer polynomial would reverse)
        return _motions(reference, lat, [min(p.lateral_durations)], lon, [stopped], objects, p, check_all=True)

    decel, name = p.vehicle.actuators.stop_deceleration, "comfortable"
    lat_m, lon_m, out, status = stop(decel)
    if status[0] == Status.COLLIDING:
        decel, name = p.vehicle.actuators.max_decel, "emergency"
        lat_m, lon_m, out, status = stop(decel)
    reason = f"{why}; {name} stop at {decel:g} m/s^2 within {v0 * v0 / (2 * decel):.1f} m"
    if status[0] == Status.COLLIDING:
        reason += ", which still collides"
    frenet = np.column_stack([lon_m[0, 0], lon_m[1, 0], lon_m[2, 0], lat_m[0, 0], lat_m[1, 0], lat_m[2, 0]])
    return Plan(p.times, *out[:, 0], frenet, math.inf, "fallback", candidates, reason), status[0] == Status.COLLIDING
