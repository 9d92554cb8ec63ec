"""CommonRoad scenarios (https://commonroad.in.tum.de): the road network and the ego's task, read with the field's
own packages: ``commonroad-io`` (reader, traffic signs, goal check) and ``commonroad-route-planner`` (route and
reference path over the lanelets). Needs the ``roads`` extra.

Positions are the file's, in its local frame (x east, y north, m), which is vilma's world frame; orientations
are counter-clockwise from +x, as vilma's yaw. The planning problem's position is taken as the car's centre of
mass (CommonRoad's reference point is the centre of the car's box).
"""

from __future__ import annotations

import math
import stat
import warnings
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from xml.etree.ElementTree import ParseError

import numpy as np

with warnings.catch_warnings():  # commonroad-io's generated protobuf modules use descriptors protobuf deprecates
    warnings.simplefilter("ignore", DeprecationWarning)
    from commonroad.common.file_reader import CommonRoadFileReader
    from commonroad.geometry.shape import Shape, ShapeGroup
    from commonroad.planning.goal import GoalRegion
    from commonroad.planning.planning_problem import PlanningProblem
    from commonroad.scenario.lanelet import LaneletNetwork
    from commonroad.scenario.scenario import Scenario
    from commonroad.scenario.state import CustomState
    from commonroad.scenario.traffic_sign import SupportedTrafficSignCountry
    from commonroad.scenario.traffic_sign_interpreter import TrafficSignInterpreter
    from commonroad_route_planner.reference_path_planner import ReferencePathPlanner
    from commonroad_route_planner.route_planner import RoutePlanner
    from shapely import LineString, Point, contains_xy, unary_union

from vilma.world.lanes import Lanes
from vilma.world.traffic import Traffic, traffic

EXTENSION_M = 50.0
"""How far [m] the reference path runs on past the route's end along the lanelets that follow (if any), so that
the car is not already braking to its final stop in a goal region at the route's end (50 km/h stops in 48 m at
2 m/s^2)."""
GOAL_SPACING_M = 0.1
"""Spacing [m] of the path samples that locate a goal region along the path."""
ACROSS_SPACING_M = 0.5
"""Spacing [m] along the path of the lines across it that measure a goal region's width."""
ACROSS_STEP_M = 0.05
"""Resolution [m] of a goal region's extent across the path."""
ACROSS_REACH_M = 20.0
"""Farthest [m] a goal region's extent is measured from the path, each side."""
MAX_FILE_BYTES = 64 << 20
"""The largest scenario file read [bytes] (the benchmark's largest are a few MB)."""


class CommonRoadError(ValueError):
    """A CommonRoad file that cannot be used: one line naming the file, the element and how to fix it."""


class RoadNetwork:
    """The lanelets of a scenario (commonroad-io's :class:`LaneletNetwork`: left and right boundaries, centre
    lines, traffic signs) and the queries a driver needs."""

    def __init__(self, lanelets: LaneletNetwork, country: str) -> None:
        self.lanelets = lanelets
        try:
            signs = SupportedTrafficSignCountry(country)
        except ValueError:  # a country without a sign catalogue: the generic one
            signs = SupportedTrafficSignCountry.ZAMUNDA
        self._signs = TrafficSignInterpreter(signs, lanelets)
        self._road = unary_union([lanelet.polygon.shapely_object for lanelet in lanelets.lanelets])

    @cached_property
    def lanes(self) -> Lanes:
        """The lanelets' centre lines, widths and successors, for prediction (:class:`~vilma.world.lanes.Lanes`)."""
        lanelets = self.lanelets.lanelets
        index = {lanelet.lanelet_id: i for i, lanelet in enumerate(lanelets)}
        return Lanes.of([lanelet.center_vertices for lanelet in lanelets],
                        [np.hypot(*(lanelet.left_vertices - lanelet.right_vertices).T) for lanelet in lanelets],
                        [[index[j] for j in lanelet.successor if j in index] for lanelet in lanelets])

    def lanelet_at(self, x: float, y: float) -> int | None:
        """The id of a lanelet holding the point ``(x, y)`` [m] (the lowest where lanelets overlap), or None."""
        ids = self.lanelets.find_lanelet_by_position([np.array([x, y])])[0]
        return min(ids) if ids else None

    def edge_distance(self, x: float, y: float) -> float:
        """Distance [m] from ``(x, y)`` to the road's edge (the outline of all lanelets): positive on the road,
        negative off it, 0 on the edge."""
        p = Point(x, y)
        d = self._road.boundary.distance(p)
        return d if self._road.covers(p) else -d

    def lateral_bounds(self, xy: np.ndarray, reach: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
        """Offsets [m] of the road's left and right edges (the outline of all lanelets) from each point of a path
        (n, 2) [m], along its left normal (left positive, right negative), looked for within ``reach`` [m]; -inf, inf
        at a point off the road (no bound there)."""
        xy = np.asarray(xy, float)
        tangent = np.gradient(xy, axis=0)
        normal = np.column_stack([-tangent[:, 1], tangent[:, 0]]) / np.hypot(*tangent.T)[:, None]
        left, right = np.full(len(xy), np.inf), np.full(len(xy), -np.inf)
        for i, (p, n) in enumerate(zip(xy, normal, strict=True)):
            across = self._road.intersection(LineString([p - reach * n, p + reach * n]))
            for piece in getattr(across, "geoms", [across]):
                if piece.length > 0 and piece.distance(Point(p)) < 1e-6:  # the stretch of road through the point
                    t = (np.asarray(piece.coords) - p) @ n
                    left[i], right[i] = t.max(), t.min()
        return left, right

    def speed_limit(self, lanelet_id: int) -> float | None:
        """The lanelet's speed limit [m/s] from its traffic signs, or None if it has none."""
        return self._signs.speed_limit(frozenset([lanelet_id]))


@dataclass(frozen=True, slots=True, kw_only=True)
class EgoTask:
    """The ego car's task from a planning problem: where it starts, the path to drive, the goal to reach."""

    file: Path
    """The CommonRoad file, resolved (with the id and the scenario's speed cap it determines the rest, which
    equality therefore skips)."""
    planning_problem_id: int
    x: float
    """Initial position [m]."""
    y: float
    yaw: float
    """Initial orientation [rad], counter-clockwise from +x."""
    speed: float
    """Initial speed [m/s]."""
    path: np.ndarray = field(compare=False)
    """The route planner's reference path from the initial position to the route's end, (n, 2) [m]."""
    path_speed: np.ndarray = field(compare=False)
    """The speed to drive at each path point [m/s], (n,): the lanelet's limit (the initial speed where it has
    none), capped by the task's speed."""
    goal: GoalRegion = field(compare=False)
    """The planning problem's goal region (position, orientation, velocity, time intervals)."""
    arrivals: tuple = field(compare=False)
    """Each goal state's windows along :attr:`path`: ((arc lo, hi) [m], (time lo, hi) [s from the initial
    state], (speed lo, hi) [m/s], its extent across the path), the fields of :class:`~vilma.trajectory.Arrival`,
    for a speed profile timed to arrive and a plan that arrives (a state the path misses left out)."""
    time_step: int
    """The initial state's time step."""
    dt: float
    """The scenario's time step [s]."""
    scenario: Scenario = field(compare=False, repr=False)
    """commonroad-io's scenario (road network and obstacles), for the benchmark's checks."""
    traffic: Traffic = field(compare=False, repr=False)
    """The scenario's obstacles on the sim clock."""
    network: RoadNetwork = field(compare=False, repr=False)
    """The road network, for the road's edges."""

    def samples(self, t: np.ndarray) -> np.ndarray:
        """The rows of a drive sampled at times ``t`` [s] from the initial state that fall on the scenario's time
        steps 0, 1, ... after it (the first sample at or after each step), (steps,) int."""
        if not len(t):
            return np.zeros(0, int)
        steps = np.arange(int(t[-1] / self.dt + 1e-9) + 1)
        return np.minimum(np.searchsorted(t, steps * self.dt - 1e-9), len(t) - 1)

    def goal_time(self, t: np.ndarray, x: np.ndarray, y: np.ndarray, yaw: np.ndarray, v: np.ndarray) -> float | None:
        """The first sim time [s] a drive (samples at times ``t`` [s] from the initial state, position [m], yaw
        [rad], speed [m/s]) is in the goal region, by the goal's own check (``GoalRegion.is_reached``) on the
        samples at the scenario's time steps; None if never."""
        for k, i in enumerate(self.samples(t)):
            state = CustomState(time_step=self.time_step + int(k), position=np.array([x[i], y[i]]),
                                orientation=float(yaw[i]), velocity=float(v[i]))
            if self.goal.is_reached(state):
                return float(k * self.dt)
        return None


@dataclass(frozen=True, slots=True, kw_only=True)
class RoadScenario:
    """A CommonRoad file read: its road network, its obstacles and its planning problems."""

    file: Path
    scenario: Scenario
    network: RoadNetwork
    planning_problems: dict[int, PlanningProblem]

    @property
    def obstacles(self) -> int:
        """How many obstacles (static and dynamic) the file holds."""
        return len(self.scenario.obstacles)

    def task(self, planning_problem: int | None = None, speed: float | None = None, ahead: float = 0.0) -> EgoTask:
        """The ego's task from the planning problem of that id (None: the file's only one), driving at the
        lanelets' speed limits capped by ``speed`` [m/s]. A path that ends where the road does (a lanelet without
        successor) ends ``ahead`` [m] before it: how far the car's box reaches ahead of its centre of mass, and the
        margin it may roll on, so that the car that stops at the path's end stays on the road.

        Raises:
            CommonRoadError: no such planning problem, or no route from the initial state to the goal.
        """
        pp = self._planning_problem(planning_problem)
        where = f"{self.file}: planningProblem {pp.planning_problem_id}"
        s0 = pp.initial_state
        with warnings.catch_warnings():  # the route planner warns through logging and warnings alike
            warnings.simplefilter("ignore")
            if not self.network.lanelets.find_lanelet_by_position([s0.position])[0]:
                raise CommonRoadError(f"{where}: the initialState's position {list(map(float, s0.position))} is on "
                                      "no lanelet; move it onto the road")
            routes = RoutePlanner(self.network.lanelets, pp).plan_routes()
            if not routes:
                raise CommonRoadError(f"{where}: no route on the lanelets from the initial state to the goal; "
                                      "check the goal's lanelets or position")
            ref = ReferencePathPlanner(self.network.lanelets, pp, routes).plan_shortest_reference_path()
        xy, dead_end = _extend(np.asarray(ref.reference_path, float), self.network.lanelets, ref.lanelet_ids[-1])
        start = int(np.argmin(np.hypot(*(xy - s0.position).T)))  # the path starts where the car does
        xy = xy[start:]
        if dead_end and ahead > 0:
            xy = _shorten(xy, ahead)
        if len(xy) < 2:
            raise CommonRoadError(f"{where}: the route ends at the initial position; check the goal")
        limits = {i: self.network.speed_limit(i) for i in ref.lanelet_ids}
        v0 = float(s0.velocity)
        v = np.array([_limit(limits, self.network.lanelets.find_lanelet_by_position([p])[0], v0) for p in xy])
        if speed is not None:
            v = np.minimum(v, speed)
        if not (v > 0).all():
            raise CommonRoadError(f"{where}: the car starts at rest on a lanelet without a speed limit; give the "
                                  "task a speed (task: {route: true, speed: 10})")
        return EgoTask(file=self.file.resolve(), planning_problem_id=pp.planning_problem_id, x=float(s0.position[0]),
                       y=float(s0.position[1]), yaw=float(s0.orientation), speed=v0, path=xy, path_speed=v,
                       goal=pp.goal, arrivals=_arrivals(pp.goal, xy, int(s0.time_step), float(self.scenario.dt)),
                       time_step=int(s0.time_step), dt=float(self.scenario.dt),
                       scenario=self.scenario, traffic=traffic(self.scenario), network=self.network)

    def _planning_problem(self, pid: int | None) -> PlanningProblem:
        ids = ", ".join(map(str, self.planning_problems)) or "none"
        if pid is None and len(self.planning_problems) == 1:
            return next(iter(self.planning_problems.values()))
        if not self.planning_problems:
            raise CommonRoadError(f"{self.file}: no planningProblem; vilma drives a file's planning problem: add one")
        if pid is None:
            raise CommonRoadError(f"{self.file}: several planning problems (ids: {ids}); name one (world: "
                                  "{planning_problem: ID})")
        if pid not in self.planning_problems:
            raise CommonRoadError(f"{self.file}: no planningProblem {pid} (ids: {ids}); name one of them")
        return self.planning_problems[pid]


def _limit(limits: dict[int, float | None], ids: list[int], default: float) -> float:
    """The speed limit [m/s] at a point on the lanelets ``ids``: the lowest of those on the route that have one."""
    known = [limits[i] for i in ids if limits.get(i) is not None]
    return min(known) if known else default


def _shorten(xy: np.ndarray, by: float) -> np.ndarray:
    """The path ``xy`` (n, 2) [m] without its last ``by`` [m] of arc (its end on the path, interpolated)."""
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    end = arc[-1] - by
    if end <= 0:
        return xy[:1]
    keep = arc < end
    last = [np.interp(end, arc, xy[:, 0]), np.interp(end, arc, xy[:, 1])]
    return np.vstack([xy[keep], last])


def _extend(xy: np.ndarray, lanelets: LaneletNetwork, last: int) -> tuple[np.ndarray, bool]:
    """The path ``xy`` (n, 2) [m] run on by :data:`EXTENSION_M` along the centre lines of the first successors of
    the lanelet ``last`` (as far as there are any), and whether it ends where the road does (at a lanelet without
    successor)."""
    seen, more, added = {last}, [xy], 0.0
    lanelet = lanelets.find_lanelet_by_id(last)
    while added < EXTENSION_M and lanelet.successor and lanelet.successor[0] not in seen:
        lanelet = lanelets.find_lanelet_by_id(lanelet.successor[0])
        seen.add(lanelet.lanelet_id)
        centre = np.asarray(lanelet.center_vertices, float)
        centre = centre[np.hypot(*(centre - more[-1][-1]).T) > 1e-6]  # the joint once
        step = np.hypot(*np.diff(np.vstack([more[-1][-1:], centre]), axis=0).T)
        keep = np.cumsum(step) - step < EXTENSION_M - added  # up to the first point at or past the length
        more.append(centre[keep])
        added += float(step[keep].sum())
    return np.vstack(more), not lanelet.successor


def _arrivals(goal: GoalRegion, xy: np.ndarray, time_step: int, dt: float) -> tuple:
    """:attr:`EgoTask.arrivals` of ``goal`` along the path ``xy`` (n, 2) [m], times from ``time_step`` (of
    ``dt`` [s]); a position's arc interval is the first stretch of the path inside it."""
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    s = np.append(np.arange(0.0, arc[-1], GOAL_SPACING_M), arc[-1])
    x, y = np.interp(s, arc, xy[:, 0]), np.interp(s, arc, xy[:, 1])
    out = []
    for state in goal.state_list:
        where = _geometry(state.position) if state.has_value("position") else None
        inside = np.ones(len(s), bool) if where is None else contains_xy(where, x, y)
        if not inside.any():
            continue
        first = int(inside.argmax())
        rest = ~inside[first:]
        last = first + (int(rest.argmax()) if rest.any() else len(rest)) - 1
        steps, speed = state.time_step, state.velocity if state.has_value("velocity") else None  # time: mandatory
        out.append(((float(s[first]), float(s[last])), ((steps.start - time_step) * dt, (steps.end - time_step) * dt),
                    (-np.inf, np.inf) if speed is None else (float(speed.start), float(speed.end)),
                    np.zeros((3, 0)) if where is None else _across(where, s[first:last + 1], x[first:last + 1],
                                                                  y[first:last + 1])))
    return tuple(out)


def _across(where, s: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """The extent of the shape ``where`` across a stretch of path inside it (arcs ``s``, points ``x``, ``y`` [m]):
    (3, m), at arcs every :data:`ACROSS_SPACING_M` and at the stretch's end, the offsets [m] (left positive) from
    and to which a line across the path, through its point, lies inside (read-only)."""
    keep = np.unique(np.append(np.searchsorted(s, np.arange(s[0], s[-1], ACROSS_SPACING_M)), len(s) - 1))
    heading = np.arctan2(np.gradient(y), np.gradient(x))[keep] if len(s) > 1 else np.zeros(1)
    centre = round(ACROSS_REACH_M / ACROSS_STEP_M)  # the index of d = 0, the path's point
    d = ACROSS_STEP_M * np.arange(-centre, centre + 1)
    across = np.column_stack([-np.sin(heading), np.cos(heading)])  # the left normals
    inside = contains_xy(where, x[keep, None] + across[:, :1] * d, y[keep, None] + across[:, 1:] * d)
    rows = []
    for k, row in zip(keep, inside, strict=True):
        if not row[centre]:  # the path's point on the shape's edge
            continue
        out_left, out_right = ~row[centre:], ~row[centre::-1]
        hi = d[centre + int(out_left.argmax()) - 1] if out_left.any() else d[-1]
        lo = d[centre - int(out_right.argmax()) + 1] if out_right.any() else d[0]
        rows.append((s[k], lo, hi))
    out = np.array(rows, dtype=np.float64).reshape(-1, 3).T
    out.flags.writeable = False  # shared by every run of the task
    return out


def _geometry(shape):
    """The shapely geometry of a commonroad-io shape (a shape group: their union)."""
    return unary_union([_geometry(x) for x in shape.shapes]) if isinstance(shape, ShapeGroup) else shape.shapely_object


def load(path: str | Path) -> RoadScenario:
    """Read the CommonRoad file ``path`` (format 2018b or 2020a, as commonroad-io reads).

    Raises:
        CommonRoadError: a missing, unreadable, too large or malformed file, or one commonroad-io refuses.
    """
    path = Path(path)
    _check_file(path)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scenario, problems = CommonRoadFileReader(path).open()
    except ParseError as e:
        raise CommonRoadError(f"{path}:{e.position[0]}: malformed XML ({e}); fix or re-export the file") from None
    except AssertionError as e:  # commonroad-io asserts the header: a format version it does not know
        raise CommonRoadError(f"{path}: commonRoad: {str(e).split(': ', 1)[-1]}") from None
    except Exception as e:  # the reader fails on a wrong element with whatever it meets there
        raise CommonRoadError(f"{path}: not a CommonRoad scenario commonroad-io can read ({type(e).__name__}: "
                              f"{' '.join(str(e).split())[:200]}); check the file against the format") from None
    _check_numbers(path, scenario, problems.planning_problem_dict)
    network = RoadNetwork(scenario.lanelet_network, scenario.scenario_id.country_id)
    return RoadScenario(file=path, scenario=scenario, network=network,
                        planning_problems=dict(problems.planning_problem_dict))


def _check_numbers(path: Path, scenario: Scenario, problems: dict[int, PlanningProblem]) -> None:
    """Refuse what commonroad-io reads but no drive can use: a lanelet, obstacle or planning problem with a number
    that is not finite (NaN, inf), a planning problem without a goal state or starting backwards.

    Raises:
        CommonRoadError: naming the element, its field and the fix.
    """
    def finite(what: str, name: str, value) -> None:
        if isinstance(value, ShapeGroup):
            for shape in value.shapes:
                finite(what, name, shape)
        elif isinstance(value, Shape):  # a shape, or an uncertain position: its numbers
            for part in ("length", "width", "radius", "center", "orientation", "vertices"):
                finite(what, name, getattr(value, part, 0.0))
        elif isinstance(value, (int, float, np.ndarray)) and not np.isfinite(value).all():
            raise CommonRoadError(f"{path}: {what}: {name} is not a finite number; fix the file")

    for lanelet in scenario.lanelet_network.lanelets:
        for side in ("left_vertices", "right_vertices", "center_vertices"):
            finite(f"lanelet {lanelet.lanelet_id}", side, getattr(lanelet, side))
    for obstacle in scenario.obstacles:
        what = f"obstacle {obstacle.obstacle_id}"
        finite(what, "shape", obstacle.obstacle_shape)
        trajectory = getattr(getattr(obstacle, "prediction", None), "trajectory", None)
        for states in ([obstacle.initial_state], trajectory.state_list if trajectory is not None else []):
            for name in states[0].attributes if states else ():
                values = [getattr(s, name) for s in states]
                if all(isinstance(v, int | float | np.ndarray) for v in values):  # a column at once (a state a step)
                    ok = np.isfinite(np.asarray(values, float).reshape(len(values), -1)).all(axis=1)
                    if not ok.all():
                        finite(f"{what} at time step {states[int(np.argmin(ok))].time_step}", name, math.nan)
                else:  # uncertain values (shapes): one by one
                    for state, value in zip(states, values, strict=True):
                        finite(f"{what} at time step {state.time_step}", name, value)
    for pid, problem in problems.items():
        what, s0 = f"planningProblem {pid}", problem.initial_state
        for name in s0.attributes:
            finite(f"{what}'s initialState", name, getattr(s0, name))
        if not problem.goal.state_list:
            raise CommonRoadError(f"{path}: {what} has no goalState; give it one")
        if s0.velocity < 0:
            raise CommonRoadError(f"{path}: {what}'s initialState: velocity {s0.velocity} m/s; vilma's car starts at "
                                  "rest or forward (>= 0)")


def _check_file(path: Path) -> None:
    """A regular file of at most :data:`MAX_FILE_BYTES`, checked without opening it (a pipe could block)."""
    try:
        st = path.stat()
    except FileNotFoundError:
        raise CommonRoadError(f"{path}: no such file; check the path") from None
    except OSError as e:
        raise CommonRoadError(f"{path}: cannot read it ({e.strerror}); check permissions") from None
    if not stat.S_ISREG(st.st_mode):
        raise CommonRoadError(f"{path}: not a regular file; give a CommonRoad .xml file")
    if st.st_size > MAX_FILE_BYTES:
        raise CommonRoadError(f"{path}: {st.st_size} bytes, over the {MAX_FILE_BYTES >> 20} MiB a scenario may hold")
