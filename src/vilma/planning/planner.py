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
from bisect import bisect_right
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import IntEnum
from functools import lru_cache, partial
from typing import NamedTuple

import numpy as np

from vilma.planning.candidates import check_candidates
from vilma.planning.frenet import FrenetFrame, FrenetState
from vilma.planning.params import PlannerParams
from vilma.planning.polynomials import evaluate, jerk_cost, quintic, to_rest
from vilma.trajectory import Arrival, Trajectory

SLOWDOWN_HORIZONS = 100
"""The steady slow-down to a target is planned over at most this many horizons: longer, it keeps the speed over
the horizon all but exactly (and its polynomial would overflow)."""
RUSHED_SPEED = 1e-6
"""How much faster [m/s] than its steady slow-down a stop that brakes harder than comfortably is planned before it
comes after those no faster (:func:`_sample`): the steady one itself, to rounding, is not."""


class Status(IntEnum):
    """What became of a candidate."""

    FEASIBLE = 0
    """Within the car's limits and free of every predicted object."""
    INFEASIBLE = 1
    COLLIDING = 2


class Candidates:
    """The candidates of a cycle, for drawing: paths ``x``, ``y`` (n, n_t) [m], :class:`Status` ``status`` (n,) and
    ``cost`` (n,). A cycle checks only the candidates it prefers to its choice: the paths and statuses of all are
    evaluated when first asked for."""

    __slots__ = ("_evaluate", "_evaluated", "cost")

    def __init__(self, cost: np.ndarray, evaluate: Callable[[], tuple[np.ndarray, np.ndarray]]) -> None:
        self.cost = cost
        self._evaluate = evaluate  # () -> (Cartesian motions (6, n, n_t), statuses (n,))
        self._evaluated: tuple[np.ndarray, np.ndarray] | None = None

    def _all(self) -> tuple[np.ndarray, np.ndarray]:
        if self._evaluated is None:
            self._evaluated, self._evaluate = self._evaluate(), None
        return self._evaluated

    @property
    def x(self) -> np.ndarray:
        """The paths' x (n, n_t) [m]."""
        return self._all()[0][0]

    @property
    def y(self) -> np.ndarray:
        """The paths' y (n, n_t) [m]."""
        return self._all()[0][1]

    @property
    def status(self) -> np.ndarray:
        """Each candidate's :class:`Status` (n,)."""
        return self._all()[1]


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
    """Longitudinal polynomials (n, 6), their durations (n,) and costs (n,); and for a stop, which of them is the
    steady slow-down to the target itself (else None)."""
    steady = None
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
        coeffs, jerk = to_rest(state.s, state.s_dot, state.s_ddot, None, v1, T)
        miss = p.speed_weight * (v1 - p.target_speed) ** 2
    else:
        durations = list(p.position_durations)
        closing = state.s_dot - target.speed
        gap = target.s - state.s
        # a stop nearer than the car's emergency stop has no steady slow-down: shorter than a step, it went to rest
        # between two samples, where no check sees its deceleration
        beyond = target.mode == "stop" and closing * closing > 2.0 * gap * p.vehicle.actuators.max_decel
        if closing > 0 and gap > 0 and not beyond:  # and the time a steady slow-down to the target speed closes the gap
            # in (at most SLOWDOWN_HORIZONS horizons: closing at a crawl it would overflow the polynomials, or itself)
            longest = SLOWDOWN_HORIZONS * p.horizon
            durations.append(max(2.0 * gap / closing, p.dt) if 2.0 * gap < closing * longest else longest)
        T = np.repeat(np.asarray(durations), len(p.position_offsets))
        dev = np.tile(np.asarray(p.position_offsets), len(durations))
        v0, v1, b = state.s_dot, target.speed, p.vehicle.actuators.stop_deceleration
        end = target.s + v1 * T + dev
        if v0 > v1 and target.mode != "stop":  # an end behind a lead the car reaches only braking harder than
            # comfortably moves on to where it does (the lead moves on too); a stop's end stays: the road may end there
            end = np.maximum(end, state.s + (v0 * v0 - v1 * v1) / (2.0 * b) + v1 * np.maximum(T - (v0 - v1) / b, 0))
        coeffs, jerk = to_rest(state.s, state.s_dot, state.s_ddot, end, np.full(len(T), v1), T)
        miss = p.position_weight * (end - target.s - v1 * T) ** 2
        if target.mode == "follow":  # the speed given up behind a slower lead, so that passing it competes
            miss = miss + p.speed_weight * max(p.target_speed - v1, 0.0) ** 2
        if target.mode == "stop" and len(durations) > len(p.position_durations):  # the steady slow-down (the last
            steady = len(T) - len(p.position_offsets) + int(np.argmax(p.position_offsets))  # duration) to the target
    return coeffs, T, p.jerk_weight * jerk + p.time_weight * T + miss, steady


def _hardest_braking(coeffs: np.ndarray, T: np.ndarray) -> np.ndarray:
    """The hardest deceleration [m/s^2] (n,) of polynomials ``coeffs`` (n, 6) over their durations ``T`` (n,) [s]
    (negative if they never brake): of their acceleration, a cubic in time, the least at its ends and where its
    derivative, the jerk, is zero."""
    c2, c3, c4, c5 = (coeffs[:, k] for k in range(2, 6))
    a, b, c = 60.0 * c5, 24.0 * c4, 6.0 * c3  # the jerk a t^2 + b t + c
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(b * b - 4.0 * a * c)  # NaN: no real root
        times = np.stack([np.zeros_like(T), T, (-b - root) / (2.0 * a), (-b + root) / (2.0 * a), -c / b])
    # (the quadratic's roots, or the line's when a = 0; a point that is neither only adds a value the least bounds)
    times = np.where(np.isfinite(times) & (times >= 0.0) & (times <= T), times, 0.0)
    accel = 2.0 * c2 + (6.0 * c3 + (12.0 * c4 + 20.0 * c5 * times) * times) * times
    return -accel.min(axis=0)


def _lateral(state: FrenetState, offsets: list[float], p: PlannerParams, keep: tuple[float, float] | None):
    """Lateral motions (3, n, n_t: offset [m], its rate and acceleration at ``p.times``) to the end ``offsets`` [m]
    in each lateral duration, their costs (n,) and end offsets and durations (n, 2) [m, s]; and ``keep`` (end offset
    [m], duration [s]) if its offset is among them. Made once for the cycles that start alike (a car keeping its lane
    starts each at no offset): read-only."""
    start = np.array(state[3:]).tobytes()  # d, d_dot, d_ddot by their bits: the sign of a zero carries on
    weights = (p.jerk_weight, p.time_weight, p.offset_weight, p.deviation_weight)
    return _lateral_from(start, tuple(offsets), p.lateral_durations, weights, keep, p.steps, p.dt)


@lru_cache(maxsize=64)
def _lateral_from(start: bytes, offsets: tuple[float, ...], durations: tuple[float, ...],
                  weights: tuple[float, float, float, float], keep: tuple[float, float] | None, steps: int, dt: float):
    """:func:`_lateral` from the lateral state ``start`` (d, d_dot, d_ddot as float64 bytes) with the ``weights``
    of jerk, time, end offset and mean squared offset, over ``steps`` of ``dt`` [s]."""
    T = np.repeat(np.asarray(durations), len(offsets))
    d1 = np.tile(np.asarray(offsets), len(durations))
    if keep is not None and keep[0] in offsets:
        T, d1 = np.append(T, keep[1]), np.append(d1, keep[0])
    coeffs = quintic(*np.frombuffer(start), d1, 0.0, 0.0, T)
    motion = evaluate(coeffs, T, np.arange(steps + 1) * dt)[:3]
    cost = weights[0] * jerk_cost(coeffs, T) + weights[1] * T + weights[2] * d1**2
    made = motion, cost + weights[3] * (motion[0] ** 2).mean(axis=1), np.column_stack([d1, T])
    for a in made:
        a.flags.writeable = False
    return made


_UNBOUNDED = np.empty((2, 0, 0))
_ONE = np.zeros(1, dtype=np.intp)


def _evaluated(fa, lat, lon, edges, ci, cj, objects, car, margin, check_all) -> tuple[np.ndarray, np.ndarray]:
    """Every candidate's Cartesian motion (6, n, n_t) and :class:`Status` (n,) (:func:`.check_candidates`)."""
    out, status = np.empty((6, len(ci), lat.shape[2])), np.empty(len(ci), dtype=np.int8)
    check_candidates(fa, lat, lon, edges, ci, cj, np.arange(len(ci)), objects, car, margin, True, check_all, out,
                     status)
    return out, status


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
    stop, collides = _fallback(state, reference, objects, params, candidates, goal)
    if collides and params.evasive_grip > 0:
        evasive = params.evasive
        found, _ = _search(state, reference, objects, evasive, goal, keep, road, arrivals)
        if found is not None:
            return replace(found, mode="evasive", reason=f"{stop.reason}: swerving instead, at up to "
                                                         f"{evasive.max_lateral_accel:.1f} m/s^2 across")
    return stop


class _Sampled(NamedTuple):
    """A cycle's candidates: lateral ``ci`` (n,) of ``lat`` (3, n_lat, n_t) with longitudinal ``cj`` (n,) of ``lon``
    (3, n_lon, n_t), their ``cost`` (n,) and ``order`` of preference (n,); each lateral motion's end offset and
    duration (n_lat, 2) [m, s]; and the first candidate of each target's group and the target."""

    lat: np.ndarray
    lon: np.ndarray
    ci: np.ndarray
    cj: np.ndarray
    cost: np.ndarray
    order: np.ndarray
    lateral: np.ndarray
    groups: list[tuple[int, _Target | None]]


def _sample(state: FrenetState, lanes: dict[_Target | None, list[float]], p: PlannerParams,
            keep: tuple[float, float] | None, arrivals: tuple[Arrival, ...]) -> _Sampled:
    """Each target's lateral motions (to its end offsets ``lanes[target]``) with its longitudinal ones, in the order
    :func:`plan` prefers them: the lateral motion to keep (while it leads away from the reference), then those in
    a goal region's window, then a stop's that brake no harder than comfortably, then its others no faster than its
    steady slow-down, then the cheapest (the first of equals). A stop faster than the steady one at some time holds
    the speed, or speeds up, to brake harder later: cheaper by the time it saves, it was chosen again each cycle
    and kept the car fast until no comfortable stop was left, then past the road's end."""
    parts, groups = [], []  # each target's (lat, lon, ci, cj, cost, kept, arrive, braking, lateral); its first one
    n_lat = n_lon = n = 0
    for target, offsets in lanes.items():
        lat_m, lat_cost, ends = _lateral(state, offsets, p, keep)
        coeffs, T, lon_cost, steady = _longitudinal(state, target, p)
        lon_m = evaluate(coeffs, T, p.times)[:3]
        i, j = np.divmod(np.arange(len(lat_cost) * len(lon_cost)), len(lon_cost))
        cost = (p.lateral_weight * lat_cost[:, None] + p.longitudinal_weight * lon_cost[None, :]).ravel()
        # the motion to keep is the last lateral one (_lateral appends it)
        kept = i == len(lat_cost) - 1 if keep is not None and keep[0] in offsets else np.zeros(len(i), bool)
        arrive = _arriving(lat_m, lon_m, arrivals, p.times).ravel() if arrivals else None
        braking = np.zeros(len(i), np.int8)
        if steady is not None:  # a stop's rank: braking no harder than comfortably, else no faster than steady
            v, harsh = lon_m[1], _hardest_braking(coeffs, T) > p.vehicle.actuators.stop_deceleration
            braking = (harsh * (1 + ((v - v[steady]).max(axis=1) > RUSHED_SPEED))).astype(np.int8)[j]
        parts.append((lat_m, lon_m, n_lat + i, n_lon + j, cost, kept, arrive, braking, ends))
        groups.append((n, target))
        n_lat, n_lon, n = n_lat + len(lat_cost), n_lon + len(lon_cost), n + len(i)
    lat, lon, ci, cj, cost, kept, arrive, braking, lateral = zip(*parts, strict=True)
    cost, braking = _joined(cost), _joined(braking)
    keys = [cost, ~np.isnan(cost)]  # (argmin's order: a NaN before any number)
    if braking.any():
        keys.append(braking)
    if arrivals:
        keys.append(~_joined(arrive))
    if keep is not None and abs(keep[0]) > abs(state.d):
        keys.append(~_joined(kept))
    return _Sampled(np.concatenate(lat, axis=1), _joined(lon, axis=1), _joined(ci), _joined(cj), cost,
                    np.lexsort(keys), _joined(lateral), groups)


def _joined(parts: tuple[np.ndarray, ...], axis: int = 0) -> np.ndarray:
    """``parts`` concatenated along ``axis``: the one part itself if it is alone (a cycle has mostly one target)."""
    return parts[0] if len(parts) == 1 else np.concatenate(parts, axis=axis)


def _search(state: FrenetState, reference: FrenetFrame, objects: np.ndarray, params: PlannerParams,
            goal: float | None, keep: tuple[float, float] | None, road: RoadBounds,
            arrivals: tuple[Arrival, ...]) -> tuple[Plan | None, Candidates]:
    """The preferred free candidate's plan (None if none is free) and every candidate (:func:`plan`)."""
    stop = None if goal is None else _Target("stop", float(goal), 0.0)
    s, d = reference.to_frenet(objects[:, :2, 0], objects[:, :2, 1]) if len(objects) else (None, None)
    lanes: dict[_Target | None, list[float]] = {}  # each target, and the end offsets that plan for it
    for lane in dict.fromkeys(params.lateral_offsets):
        lead = None if s is None else _lead_target(state, s, d, objects, lane, params)
        targets = [t for t in (lead, stop) if t is not None and _binds(t, state, params)]
        lanes.setdefault(min(targets, key=lambda t: t.s + t.speed * params.horizon, default=None), []).append(lane)
    c = _sample(state, lanes, params, keep, arrivals)
    edges = (np.stack([np.interp(c.lon[0], road.s, road.left), np.interp(c.lon[0], road.s, road.right)])
             if len(road.s) else _UNBOUNDED)
    fa, car, n = reference.arrays, _car(params), len(c.cost)
    candidates = Candidates(c.cost, partial(_evaluated, fa, c.lat, c.lon, edges, c.ci, c.cj, objects, car,
                                            params.margin, False))
    out, status = np.empty((6, n, len(params.times))), np.empty(n, dtype=np.int8)
    chosen = check_candidates(fa, c.lat, c.lon, edges, c.ci, c.cj, c.order, objects, car, params.margin, False, False,
                              out, status)
    if chosen < 0:
        return None, candidates
    target = c.groups[bisect_right([g[0] for g in c.groups], chosen) - 1][1]
    i, j = c.ci[chosen], c.cj[chosen]
    frenet = np.column_stack([c.lon[0, j], c.lon[1, j], c.lon[2, j], c.lat[0, i], c.lat[1, i], c.lat[2, i]])
    mode = "velocity" if target is None else target.mode
    return Plan(params.times, *out[:, chosen], frenet, float(c.cost[chosen]), mode, candidates,
                lateral=(float(c.lateral[i, 0]), float(c.lateral[i, 1]))), candidates


def _arriving(lat_m: np.ndarray, lon_m: np.ndarray, arrivals: tuple[Arrival, ...], t: np.ndarray) -> np.ndarray:
    """Whether each pair of lateral and longitudinal motions (3, n, n_t: position, rate, acceleration) is in one of
    the ``arrivals`` at one of the times ``t`` [s] (n_lat, n_lon)."""
    s, v, d = lon_m[0], lon_m[1], lat_m[0]
    out = np.zeros((d.shape[0], s.shape[0]), bool)
    for w in arrivals:
        on = w.reached(s, t[None], v)
        if not on.any():
            continue
        if w.d.shape[1]:
            on = on[None] & w.across(s[None], d[:, None])
        out |= on.any(axis=-1)
    return out


def _fallback(state: FrenetState, reference: FrenetFrame, objects: np.ndarray, p: PlannerParams,
              candidates: Candidates, goal: float | None = None) -> tuple[Plan, bool]:
    """The safe stop: along the reference at the comfortable deceleration (the car's controlled stop), harder where
    that would pass the ``goal`` [m] (the road may end there: on it, up to the emergency deceleration), or at the
    emergency deceleration when the stop collides; the lane offset settles where it is. And whether it still
    collides."""
    infeasible = int((candidates.status == Status.INFEASIBLE).sum())
    why = f"no free candidate: {infeasible} infeasible, {len(candidates.status) - infeasible} colliding"
    settle = min(p.lateral_durations)
    lat = evaluate(quintic(state.d, state.d_dot, state.d_ddot, state.d, 0.0, 0.0, settle)[None], settle, p.times)[:3]
    v0 = max(state.s_dot, 0.0)

    def stop(decel):
        lon = np.array([[state.s, v0, -0.5 * decel if v0 > 0 else 0.0, 0.0, 0.0, 0.0]])
        stopped = v0 / decel if v0 > 0 else p.dt  # at rest from then on (a longer polynomial would reverse)
        lon_m = evaluate(lon, stopped, p.times)[:3]
        return (lon_m, *_evaluated(reference.arrays, lat, lon_m, _UNBOUNDED, _ONE, _ONE, objects, _car(p), p.margin,
                                   True))

    decel, name = p.vehicle.actuators.stop_deceleration, "comfortable"
    if goal is not None and goal > state.s and v0 * v0 > 2.0 * decel * (goal - state.s):
        decel, name = min(v0 * v0 / (2.0 * (goal - state.s)), p.vehicle.actuators.max_decel), "goal's"
    lon_m, out, status = stop(decel)
    if status[0] == Status.COLLIDING:
        decel, name = p.vehicle.actuators.max_decel, "emergency"
        lon_m, out, status = stop(decel)
    reason = f"{why}; {name} stop at {decel:.3g} m/s^2 within {v0 * v0 / (2 * decel):.1f} m"
    if status[0] == Status.COLLIDING:
        reason += ", which still collides"
    frenet = np.column_stack([lon_m[0, 0], lon_m[1, 0], lon_m[2, 0], lat[0, 0], lat[1, 0], lat[2, 0]])
    return Plan(p.times, *out[:, 0], frenet, math.inf, "fallback", candidates, reason), status[0] == Status.COLLIDING
