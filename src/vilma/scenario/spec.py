"""Scenario files: YAML validated into the typed objects the simulator and the driver take.

A five-line file is enough::

    task:
      course: [[0, 0], [100, 0], [100, -30], [50, -20], [60, 0]]
      speed: 8.33
    speed_controller: pi_ff
    path_controller: stanley

Top-level keys (all optional but ``task``):

- ``name``, ``description``: text (name defaults to the file's stem).
- ``vehicle``: a preset name (``vilma``, ``bmw_320i``), a parameter file (``*.yaml``, relative to the
  scenario), or a mapping of :class:`~vilma.vehicle.params.VehicleParams` fields with an optional
  ``preset`` to start from. ``actuators``: :class:`~vilma.vehicle.params.ActuatorParams` fields.
- ``plant`` (``kinematic`` | ``single_track`` | ``mujoco``), ``integrator`` (``rk4`` | ``euler``), ``step``
  [s], ``seed``, ``watchdog_timeout`` [s]. ``world``: ``boxes`` and ``cones`` (on flat ground, standing still,
  seen by the laser and the objects sensor, their collisions the scorecard's; not beside a CommonRoad world); with
  ``plant: mujoco`` only: ``ramps``, ``bumps``, ``ground_friction`` (:mod:`vilma.plant3d.world`), ``cameras`` (a list of
  :class:`~vilma.plant3d.camera.CameraParams` fields, or ``{stereo: {baseline: 0.3, ...}}`` for the front
  pair) and ``laser`` (``true`` or :class:`~vilma.plant3d.laser.LaserParams` fields).
- ``sensors``: per sensor its parameter fields (``gps: {horizontal_noise: 0.5, rate_hz: 10}``), or
  ``false`` to remove it; ``origin``: the geodetic origin of the local frame.
- ``pose``: ``truth`` or ``ekf``. ``speed_controller`` / ``path_controller``: a name, or a mapping with
  ``type`` (default: the driver's controller) and that controller's parameter fields. ``driver``: other
  :class:`~vilma.control.driver.DriverParams` fields, and ``original: true`` for the shipped program.
- ``speed_log``: a speed log of the original program to overlay and compare (``data/SpeedLog10.txt``).
- ``traffic``: with ``world: {commonroad: file.xml}``, ``recorded`` (default: as in the file) or ``reactive``
  (IDM along the recorded paths behind the car ahead, the ego included: :mod:`vilma.world.reactive`).
- ``task``: see :class:`~vilma.scenario.task.TaskSpec`. With ``task: {plan: ...}``: ``planner``, the
  :class:`~vilma.planning.PlannerParams` fields but ``vehicle`` and ``target_speed`` (the car's and the task's;
  ``replan_period`` 0.1 s by default, a whole number of driver periods), and ``perception``: ``truth`` (the
  ``objects`` sensor's readings, the sensor on with its defaults if the scenario has none) or ``laser`` (the
  ``laser`` sensor's scans segmented, boxed and tracked). ``initial``: see
  :class:`~vilma.scenario.task.InitialSpec`. ``duration``: the longest
  drive [s], at most :data:`~vilma.scenario.drive_log.MAX_ROWS` driver periods (the run keeps a log row
  a period: a day at the default 50 Hz driver, 12 h at 100 Hz). ``metrics``: see
  :class:`~vilma.scenario.scorecard.MetricsSpec`.
  ``expect``: pass criteria, ``{key: {min, max}}`` on scorecard keys (``completed: true`` for a boolean).
"""


from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from vilma.control.driver import DriverParams
from vilma.core.extras import require
from vilma.scenario.bundled import find_scenario
from vilma.scenario.drive_log import COLUMNS, MAX_ROWS
from vilma.scenario.driver_keys import driver_period, read_driver
from vilma.scenario.fields import Key, Source, SpecError, _suggest, build, convert, get, load_yaml, read_yaml
from vilma.scenario.plan_keys import read_perception, read_planner
from vilma.scenario.scorecard import BOOLEAN_KEYS, SCORECARD_KEYS, TIMING_KEYS, Bound, MetricsSpec
from vilma.scenario.simulation import ROAD_KEYS, SWITCHED, read_sim
from vilma.scenario.task import InitialSpec, TaskSpec
from vilma.sensors import SensorSuite
from vilma.sensors.objects import ObjectsParams
from vilma.sim import SimConfig
from vilma.sim.config import MUJOCO
from vilma.trajectory import (
    Arrival,
    Trajectory,
    TrajectoryFileError,
    arrival_profile,
    densify,
    load_speed_log,
    load_trajectory,
    resample,
    speed_profile,
)
from vilma.trajectory.points import MAX_POINTS
from vilma.trajectory.smooth import smooth_banded, smooth_iterative
from vilma.vehicle.params import PRESETS

if TYPE_CHECKING:  # the roads extra is imported when a scenario names a CommonRoad file; the planner for a plan
    from vilma.planning import PlannerParams
    from vilma.world.commonroad import EgoTask


COURSE_SPACING = 0.5
"""A ``course``'s points are this far apart along it [m]."""


@lru_cache(maxsize=8)  # a sweep or a benchmark drives one course many times: one spline for them all
def _course(points: tuple[tuple[float, float], ...]) -> Trajectory:
    """:func:`~vilma.trajectory.course.course` through ``points`` (a trajectory is immutable: shared)."""
    from vilma.trajectory.course import course

    return course(points, COURSE_SPACING)

@dataclass(frozen=True, slots=True, kw_only=True)
class Scenario:
    """A validated scenario: everything a run needs."""

    name: str
    description: str = ""
    file: Path | None = None
    """The file it came from (relative paths in it are relative to its folder)."""
    sim: SimConfig = field(default_factory=SimConfig)
    driver: DriverParams = DriverParams()
    task: TaskSpec
    initial: InitialSpec = InitialSpec()
    duration: float = 120.0
    """Longest drive [s]."""
    metrics: MetricsSpec = MetricsSpec()
    expect: dict[str, Bound | bool] = field(default_factory=dict)
    speed_log: str | None = None
    """A speed log of the original program (time, speed) to compare with, relative to the scenario file."""
    road: EgoTask | None = None
    """The task of a CommonRoad planning problem (``world.commonroad``) for a ``route`` task."""
    traffic: str = "recorded"
    """How a road's traffic drives: ``recorded`` (as in the file) or ``reactive`` (IDM along the recorded paths,
    :mod:`vilma.world.reactive`)."""
    planner: PlannerParams | None = None
    """The local planner of a ``plan`` task (None for the others)."""
    perception: str | None = None
    """What a ``plan`` task perceives with: ``truth`` (the objects sensor) or ``laser`` (None for the others)."""

    def reference_path(self) -> Trajectory | None:
        """The path the task follows (loaded, densified, smoothed, resampled), or None for a speed task; a plan's
        route with its speeds, ending at the plan's goal."""
        t = self.task
        if t.kind == "speed":
            return None
        if t.kind == "go_to":
            return None  # the driver plans it from where the car is
        if t.kind == "plan":
            return self._plan_route()
        if t.kind == "route":
            return self._route()
        return self._path()

    def _path(self) -> Trajectory:
        """The ``course`` or ``follow`` path, densified, smoothed, resampled."""
        t = self.task
        if t.course is not None:
            path = _course(t.course)
        else:
            try:
                path = load_trajectory(self.trajectory_file())
            except TrajectoryFileError as e:
                raise SpecError(str(e)) from None
        try:
            path = densify(path, t.densify)
            if t.smooth is not None:
                s = t.smooth
                xy = (smooth_iterative(path.xy, s.alpha, s.beta, s.tolerance) if s.solver == "iterative"
                      else smooth_banded(path.xy, s.alpha, s.beta))
                path = Trajectory(xy, path.speed)
            if t.resample is not None:
                path = resample(path, t.resample)
        except ValueError as e:  # too many points for this path
            raise SpecError(f"{self.file or self.name}: task: {e}") from None
        return path

    def _route(self) -> Trajectory:
        """The planning problem's route at the lanelets' speeds, capped to arrive in the goal's windows where
        the limits alone would not (:func:`~vilma.trajectory.arrival_profile`)."""
        road, d = self.road, self.driver
        path = speed_profile(Trajectory(road.path, road.path_speed), None, d.max_lateral_accel, d.stop_deceleration)
        timed = arrival_profile(path, road.speed, d.max_accel, d.stop_deceleration,
                                tuple(Arrival(*w) for w in road.arrivals))
        return path if timed is None else timed

    def _plan_route(self) -> Trajectory:
        """A plan's route: the CommonRoad route (``route``, or none of ``follow`` and ``course`` given) or the path,
        at the task's speed or its own, lowered in curves, cut where the goal projects on it."""
        t, d = self.task, self.driver
        routed = t.route or (t.course is None and t.follow is None)
        try:
            path = self._route() if routed else speed_profile(self._path(), t.speed, d.max_lateral_accel,
                                                              d.stop_deceleration)
            return path if t.plan.goal is None else path.cut_at(t.plan.goal)
        except ValueError as e:
            raise SpecError(f"{self.file or self.name}: task: {e}") from None

    def trajectory_file(self) -> Path:
        """The ``follow`` file, resolved against the scenario's folder."""
        return beside(self.file, self.task.follow)


def beside(file: Path | None, name: str) -> Path:
    """``name`` resolved against the folder of ``file`` (unless absolute)."""
    p = Path(name).expanduser()
    return p if p.is_absolute() or file is None else file.parent / p


TOP_KEYS = ("name", "description", "vehicle", "actuators", "plant", "world", "cameras", "laser", "objects",
            "integrator", "step", "seed", "watchdog_timeout", "sensors", "origin", "pose", "speed_controller",
            "path_controller", "driver", "task", "initial", "duration", "metrics", "expect", "speed_log", "traffic",
            "planner", "perception")


TASK_KINDS = ("task", "route", "plan", "go_to", "follow", "course")
"""The ``task`` keys that say what the task is (``task`` itself, replaced whole): an override of a CommonRoad file
that sets one replaces its default plan; other ``task`` keys (``speed``) tune it."""
TRAFFIC = ("recorded", "reactive")
"""The ways a CommonRoad world's traffic drives (``traffic``)."""


def load_scenario(path: str | Path, overrides: dict[str, str] | None = None) -> Scenario:
    """Read and validate the scenario file ``path``, or the bundled scenario of that name (``course_30kmh_stanley``);
    ``overrides`` maps dotted keys to YAML values (``--set``). A CommonRoad file (``.xml``) is its planning problem,
    planned (``task: {plan: true}``) unless an override sets the task (``--set task.route=true``: the route
    followed)."""
    if Path(path).suffix == ".xml":  # a CommonRoad file: its planning problem planned, with vilma's defaults
        path = Path(path)
        planned = {} if _sets_kind(overrides or {}) else {"task": {"plan": True}}
        return parse_scenario({"world": {"commonroad": path.name}, **planned}, Source(str(path), {}), name=path.stem,
                              file=path, overrides=overrides)
    path = find_scenario(path)
    data, src = read_yaml(path)
    return parse_scenario(data, src, name=path.stem, file=path, overrides=overrides)


# The sections are read top-down by the hand-written readers of vilma.scenario.fields, not by msgspec (a
# dependency already): msgspec.convert onto these dataclasses ignores unknown keys (no "did you mean"), locates
# an error by path ($.task.speed) but not by line, cannot merge a mapping onto a preset (vehicle: {preset:
# bmw_320i, mass: 1500}) and refuses "smooth: true" for a SmoothSpec | None.
def parse_scenario(data: Any, src: Source, name: str = "scenario", file: Path | None = None,
                   overrides: dict[str, str] | None = None) -> Scenario:
    """A :class:`Scenario` from parsed YAML ``data`` (see the module docstring for the keys), read section by
    section in the order of :data:`TOP_KEYS`; each section is checked against the ones before it."""
    data, src = _document(data, src, overrides or {})
    name, description = get(data, src, ("name",), str, name), get(data, src, ("description",), str, "")
    sim = read_sim(data, src, Path(file).parent if file is not None else Path.cwd())
    driver = read_driver(data, src)
    period = driver_period(driver, sim, src)
    top = sim.vehicle.top_speed
    task = _task(data, src, top, file)
    metrics = build(MetricsSpec, data.get("metrics"), src, ("metrics",))
    car = sim.vehicle  # a route to where the road ends stops with the car's front on it, within the end tolerance
    road = _road(data, src, task, file, car.length / 2 + car.body_offset + metrics.end_tolerance)
    if road is not None and sim.traffic is not None:
        raise src.error(("world",), "boxes and cones on flat ground go without a CommonRoad world: remove them, or "
                                    f"use plant: {MUJOCO}")
    if road is not None:  # what the flat-ground laser, the objects sensor and the 3D plant see
        from vilma.world.road_view import road_view  # the roads extra, which _road required

        sim = dataclasses.replace(sim, traffic=road.traffic, traffic_t0=road.time_step * road.dt,
                                  road=road_view(road).lanelets if sim.model == MUJOCO else ())
    planner, perception = read_planner(data, src, task, sim, period), read_perception(data, src, task, sim)
    if perception == "truth" and sim.objects is None:  # a plan perceives: truth is the objects sensor's
        sim = dataclasses.replace(sim, objects=ObjectsParams())
    return Scenario(
        name=name, description=description, file=file, sim=sim, driver=driver, task=task,
        initial=_initial(data, src, top, road), duration=_duration(data, src, period),
        metrics=metrics, expect=_expect(data.get("expect"), src),
        speed_log=_speed_log(data, src, file), road=road, traffic=_traffic(data, src, road),
        planner=planner, perception=perception)


def _speed_log(data: dict, src: Source, file: Path | None) -> str | None:
    """``speed_log``, a file beside ``file`` read now: a bad one is refused before the run, not after it."""
    name = get(data, src, ("speed_log",), str, None)
    if name is not None:
        try:
            load_speed_log(beside(file, name))
        except ValueError as e:
            raise src.error(("speed_log",), str(e)) from None
    return name


def _traffic(data: dict, src: Source, road: EgoTask | None) -> str:
    """``traffic``: ``recorded`` or ``reactive``, for a CommonRoad world only."""
    value = get(data, src, ("traffic",), str, "recorded")
    if value not in TRAFFIC:
        raise src.error(("traffic",), f"unknown traffic {value!r}; use one of {', '.join(TRAFFIC)}")
    if "traffic" in data and road is None:
        raise src.error(("traffic",), "only for a CommonRoad world: add world: {commonroad: file.xml} or remove it")
    return value


def _sets_kind(overrides: dict[str, str]) -> bool:
    """Whether ``overrides`` say what the task is (:data:`TASK_KINDS`): a default task then gives way to theirs."""
    return any(k.split(".")[:2][-1] in TASK_KINDS for k in overrides)


def _document(data: Any, src: Source, overrides: dict[str, str]) -> tuple[dict, Source]:
    """The scenario's mapping with the ``overrides`` applied, its keys checked."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise src.error((), "a scenario must be a mapping of keys such as task, vehicle, speed_controller")
    if "task" not in data and _road_keys(data.get("world")) and not _sets_kind(overrides):
        data = {**data, "task": {"route": True}}  # a CommonRoad world: its route, which --set task.speed caps
    data, src = apply_overrides(data, src, overrides)
    for k in data:
        if k not in TOP_KEYS:
            raise src.error((k,), f"unknown key{_suggest(str(k), TOP_KEYS)}")
    if "task" not in data and _road_keys(data.get("world")):
        data = {**data, "task": {"route": True}}  # (a world set by --set)
    if "task" not in data:
        raise src.error((), "no task: add e.g. 'task: {speed: 10}' or 'task: {follow: path.txt, speed: 5}'")
    return data, src


def _task(data: dict, src: Source, top_speed: float, file: Path | None) -> TaskSpec:
    """``task``, its speed within the car's ``top_speed`` [m/s] and its ``follow`` file beside ``file``."""
    task = build(TaskSpec, data["task"], src, ("task",))
    _check_speed(task.speed, top_speed, src, ("task", "speed"))
    if task.course is not None:  # the spline's points, a point every COURSE_SPACING m
        chords = np.hypot(*np.diff(np.array(task.course), axis=0).T)
        if not (chords > 0).all():
            i = int(np.argmin(chords > 0)) + 1
            raise src.error(("task", "course", i), "the same point as the one before: a course's points must differ")
        if not chords.sum() <= MAX_POINTS * COURSE_SPACING:
            raise src.error(("task", "course"), f"{chords.sum():.4g} m long, more than the "
                                                f"{MAX_POINTS * COURSE_SPACING / 1000:g} km a course may be")
    if task.follow is not None and not beside(file, task.follow).is_file():
        raise src.error(("task", "follow"), f"no such trajectory file {beside(file, task.follow)}")
    return task


def _road_keys(world: Any) -> dict:
    """The CommonRoad keys of the ``world`` section."""
    return {k: v for k, v in world.items() if k in ROAD_KEYS} if isinstance(world, dict) else {}


def _road(data: dict, src: Source, task: TaskSpec, file: Path | None, ahead: float = 0.0) -> EgoTask | None:
    """The planning problem's task from ``world.commonroad`` (a file beside ``file``) for a ``route`` task; a route
    to where the road ends stops ``ahead`` [m] before it (:meth:`~vilma.world.commonroad.RoadScenario.task`)."""
    road = _road_keys(data.get("world"))
    routed = task.route or (task.plan is not None and task.course is None and task.follow is None)
    if not road:
        if routed:
            raise src.error(("task", "route" if task.route else "plan"),
                        "a route needs a CommonRoad scenario: world: {commonroad: file.xml}, or give a plan follow "
                        "or course")
        return None
    if "commonroad" not in road:
        raise src.error(("world", "planning_problem"), "a planning problem needs its file: world: {commonroad: "
                                                       "file.xml}")
    if not routed:  # it would drive off the road's planning problem, its traffic unseen and unscored
        what = "a plan along a course or a file" if task.plan is not None else f"a {task.kind} task"
        raise src.error(("task",), f"{what} does not drive a CommonRoad world's planning problem: give task: "
                                   "{route: true} or {plan: true} (a speed caps the lanelets' limits), or remove "
                                   "world.commonroad")
    xml = beside(file, get(road, src, ("world", "commonroad"), str))
    if not xml.exists():  # a mistyped name is said as such, not as an extra to install
        raise SpecError(f"{xml}: no such file; check the path")
    require("roads", "a CommonRoad scenario")
    from vilma.world.commonroad import CommonRoadError, load

    pid = get(road, src, ("world", "planning_problem"), int, None)
    try:
        scenario = load(xml)
        return scenario.task(pid, task.speed, ahead) if routed else None
    except CommonRoadError as e:
        raise SpecError(str(e)) from None


def _initial(data: dict, src: Source, top_speed: float, road: EgoTask | None = None) -> InitialSpec:
    """``initial`` (by default the planning problem's initial state), its speed within the car's ``top_speed``
    [m/s] either way."""
    start = InitialSpec(x=road.x, y=road.y, yaw=road.yaw, speed=road.speed) if road is not None else InitialSpec()
    initial = build(InitialSpec, data.get("initial"), src, ("initial",), start)
    _check_speed(initial.speed, top_speed, src, ("initial", "speed"))
    return initial


def _check_speed(speed: float | None, top: float, src: Source, key: Key) -> None:
    if speed is not None and abs(speed) > top:
        raise src.error(key, f"{speed:g} m/s is faster than the car's top speed, {top:.2f} m/s (its max_power "
                             "against drag and rolling resistance); give a lower speed")


def _duration(data: dict, src: Source, period: float) -> float:
    """``duration`` [s]: positive, and at most :data:`MAX_ROWS` driver periods of ``period`` [s]."""
    duration = get(data, src, ("duration",), float, 120.0)
    if not duration > 0:
        raise src.error(("duration",), f"must be > 0 s, got {duration}")
    if duration / period > MAX_ROWS:  # the log keeps a row a driver period
        raise src.error(("duration",), f"{duration:.12g} s is more than the {MAX_ROWS} driver periods of {period:g} "
                                       f"s a run keeps (a log row each, {MAX_ROWS * 8 * len(COLUMNS) / 1e9:.2f} GB); "
                                       f"give at most {MAX_ROWS * period:g} s")
    return duration


def _expect(raw: Any, src: Source) -> dict[str, Bound | bool]:
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise src.error(("expect",), "expected a mapping such as {lateral_error_rms_m: {max: 0.1}}")
    out: dict[str, Bound | bool] = {}
    keys = [k for k in SCORECARD_KEYS if k not in (*TIMING_KEYS, "incomplete_reason", "traffic", "perception",
                                                   "planner", "planner_reason")]
    for k, v in raw.items():
        if k in TIMING_KEYS:
            raise src.error(("expect", k), "wall-clock figures vary with the machine and are not pass criteria; "
                            "see benchmarks/ for speed targets")
        if k not in keys:
            raise src.error(("expect", k), f"not a scorecard key; use one of {', '.join(keys)}")
        if k in BOOLEAN_KEYS:
            out[k] = convert(bool, v, src, ("expect", k))
        else:
            bound = build(Bound, v, src, ("expect", k))
            if bound.min is None and bound.max is None:
                raise src.error(("expect", k), "give min, max or both")
            out[k] = bound
    return out


def apply_overrides(data: dict, src: Source, overrides: dict[str, str]) -> tuple[dict, Source]:
    """``data`` with each dotted key set to its YAML value; errors name the ``--set`` they came from."""
    if not overrides:
        return data, src
    data = copy.deepcopy(data)
    lines = dict(src.lines)
    for dotted_key, text in overrides.items():
        label = f"--set {dotted_key}={text}"
        parts = dotted_key.split(".")
        if not all(parts):
            raise SpecError(f"{label}: the key must be dotted names such as task.speed")
        try:
            value, _ = load_yaml(text, label)
        except SpecError:
            value = text  # not YAML: take it as text
        node = data
        for i, part in enumerate(parts[:-1]):
            nxt = node.get(part)
            if isinstance(nxt, str) and part in ("speed_controller", "path_controller"):
                nxt = {"type": nxt}  # --set speed_controller.kp=... on a file that names only the type
            if i == 0 and part == "vehicle" and (nxt is None or nxt in PRESETS):
                nxt = {"preset": nxt or "vilma"}  # --set vehicle.mass=...: the file's preset (or the default's) changed
            if nxt is None or (i == 0 and part in SWITCHED and nxt is True):
                nxt = {}  # (laser: true is the defaults: --set laser.rate_hz=20 changes one of them)
            if not isinstance(nxt, dict):
                raise SpecError(f"{label}: {'.'.join(parts[:i + 1])} is not a mapping in the scenario")
            node[part] = nxt
            node = nxt
        node[parts[-1]] = value
        lines[tuple(parts)] = label
    return data, Source(src.name, lines)


def to_yaml(scenario: Scenario) -> str:
    """The resolved scenario as YAML that :func:`load_scenario` reads back to an equal scenario."""

    def plain(v: Any) -> Any:
        if dataclasses.is_dataclass(v):
            return {f.name: plain(getattr(v, f.name)) for f in dataclasses.fields(v)}
        if isinstance(v, tuple | list):
            return [plain(x) for x in v]
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items()}
        return v

    s = scenario
    d = s.driver
    task = plain(s.task)
    if s.task.follow is not None:
        task["follow"] = str(s.trajectory_file().resolve())
    out = {
        "name": s.name, "description": s.description, "vehicle": plain(s.sim.vehicle), "plant": s.sim.model,
        **({"world": {**(plain(s.sim.world) if not s.sim.world.empty else {}),
                      **({"commonroad": str(s.road.file.resolve()), "planning_problem": s.road.planning_problem_id}
                         if s.road is not None else {})}} if not s.sim.world.empty or s.road is not None else {}),
        **({"cameras": plain(s.sim.cameras)} if s.sim.cameras else {}),
        **({"laser": plain(s.sim.laser)} if s.sim.laser is not None else {}),
        **({"objects": plain(s.sim.objects)} if s.sim.objects is not None else {}),
        "integrator": s.sim.integrator, "step": s.sim.step, "seed": s.sim.seed,
        "watchdog_timeout": s.sim.watchdog_timeout,
        "sensors": {k: (plain(v) if v is not None else False) for k, v in
                    ((f.name, getattr(s.sim.sensors, f.name)) for f in dataclasses.fields(SensorSuite))},
        "pose": d.pose_source,
        "speed_controller": {"type": d.speed_controller, **plain(d.gains_of(d.speed_controller))},
        "path_controller": {"type": d.path_controller, **plain(d.gains_of(d.path_controller))},
        "driver": {f.name: plain(getattr(d, f.name)) for f in dataclasses.fields(d)
                   if f.name not in ("speed_controller", "path_controller", "pose_source", "gains")},
        "task": {k: v for k, v in task.items() if v is not None and v is not False},
        "initial": {k: v for k, v in plain(s.initial).items() if v is not None},
        "duration": s.duration, "metrics": plain(s.metrics),
        **({"speed_log": str(beside(s.file, s.speed_log).resolve())} if s.speed_log else {}),
        **({"traffic": s.traffic} if s.road is not None else {}),
        **({"planner": {k: v for k, v in plain(s.planner).items() if k not in ("vehicle", "target_speed")},
            "perception": s.perception} if s.planner is not None else {}),
        "expect": {k: (v if isinstance(v, bool) else {b: x for b, x in plain(v).items() if x is not None})
                   for k, v in s.expect.items()},
    }
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)  # libyaml's where there: a third of the time, same text
    return yaml.dump(out, Dumper=dumper, sort_keys=False)
