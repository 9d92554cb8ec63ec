"""``vilma report RUN.mcap``: the scorecard and the plots of a drive from its recording alone.

The recording of a ``vilma run`` holds the runner's row a control period
(``drive_log``), the scenario (``scenario.yaml``), the path driven
(``path.csv``) and when the task began (``run`` metadata): the scorecard is
recomputed from them with :func:`vilma.scenario.metrics.scorecard`, every key
but the timing ones equal to the run's ``metrics.json``, and the plots drawn
with :func:`vilma.scenario.report.plot_run`, as the run did.

A live recording (``vilma up``, ``vilma sim --record``) has no ``drive_log``:
its rows are rebuilt from the pose, velocity, actuator and driver topics at
each pose. Its task is the driver's last order (``driver/cmd``: the orders the
driver took, a go-to's and a follow's with the points of the path), else the
driver's mode (``driver/status``: a speed task at its target, a path the
scenario's if it has one); a task the recording does not tell is not scored:
the speed-step and path keys are null, and so is ``completed``.

A reset of the simulator (its clock starts again: :class:`~vilma.record.reader.Epochs`),
or a jump of the car farther than it could move between two rows, starts a new
segment. Each segment is scored on its own (``segments`` in ``metrics.json``);
the scorecard is the last segment's (the drive the recording ends with: its
task, errors and collisions since the reset), but ``distance_m`` and
``sim_time_s``, which are summed over the segments.

A recording cut short (no footer: its writer was killed; or a ``vilma run``
recording without the run's ``run`` metadata: Ctrl-C) is ``truncated``, its task
not completed. Timing keys: ``loop_wall_time_s`` and ``load_time_s`` are the
run's (the recording's ``scorecard`` metadata; null if absent or live),
``realtime_factor`` the run's from them, ``controller_time_per_step_us`` from the
rows; ``wall_time_s`` is null: a report times no drive. Collisions come from the
run's ``scorecard`` metadata, or the segment's last ``sim/status``. Camera
images and laser scans are not scored; :func:`world_counts` counts them.

A planned drive's plots show its planning cycles (``planning/plan``: their time, mode and fallbacks) and the tracks
of each scan (``perception/objects``) in the last segment (:func:`planning_log`); its perception and planning keys
(CLEAR MOT's among them) are the run's, from its ``scorecard`` metadata.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import msgspec
import numpy as np

from vilma.core.files import write_atomic
from vilma.core.messages import DriverOrder, SimStatus
from vilma.record.reader import Recording, RecordingError, read_recording
from vilma.record.schemas import DRIVE_LOG
from vilma.scenario.drive_log import COLUMNS, PLANT_COLUMNS, DriveLog
from vilma.scenario.fields import load_yaml
from vilma.scenario.metrics import WATCHDOG_STOP, check_expectations, expectation_failures, scorecard, timing
from vilma.scenario.plan_keys import PLANNING_KEYS
from vilma.scenario.result import PlanningLog, RunResult
from vilma.scenario.spec import TIMING_KEYS, Scenario, TaskSpec, parse_scenario
from vilma.trajectory import Trajectory

TASK_ACTIONS = ("manual", "set_speed", "hold_speed", "go_to", "follow")
"""Driver orders that give it a task (``tune`` does not)."""
UNKNOWN = TaskSpec(follow="(not in the recording)")
"""Stands in for a task the recording does not tell: with no path it scores neither a speed step nor a path."""
MAX_ACCEL = 20.0
"""More than any car's speed changes in a second [m/s^2] (2 g): what bounds its move between two rows."""
JUMP_SLACK = 0.5
"""A move between two rows this much [m] beyond what the car's speed allows is a jump (a reset)."""


@dataclass(frozen=True)
class Task:
    """The driver's task from ``t_start`` [s] of clock epoch ``epoch``, as far as the recording tells: the spec
    to score it by and its path, or None and ``why`` not."""

    epoch: int
    t_start: float
    spec: TaskSpec | None
    path: Trajectory | None = None
    why: str | None = None


@dataclass
class Report(RunResult):
    """A recording's report: the scorecard as the module docstring says, and each segment's."""

    segments: list[dict] = field(default_factory=list)
    """When each segment began (``start_s`` [s], ``began``: ``start``, ``reset`` or ``jump``) and its scorecard
    (without the timing keys)."""


def scenario_of(rec: Recording) -> Scenario:
    """The scenario kept in the recording, or the defaults with no task known if it has none."""
    if "scenario.yaml" not in rec.attachments:
        return Scenario(name=rec.path.stem, task=UNKNOWN)
    data, src = load_yaml(rec.attachments["scenario.yaml"].decode(), f"{rec.path}:scenario.yaml")
    return parse_scenario(data, src, name=data.get("name", rec.path.stem) if isinstance(data, dict) else "run")


def path_of(rec: Recording, scenario: Scenario) -> Trajectory | None:
    """The path the run drove: the ``path.csv`` attachment, else the scenario's (None for a speed task)."""
    if "path.csv" in rec.attachments:
        a = np.loadtxt(rec.attachments["path.csv"].decode().splitlines(), delimiter=",", ndmin=2)
        return Trajectory(a[:, :2], a[:, 2] if a.shape[1] > 2 else None)
    try:
        return scenario.reference_path()
    except (OSError, ValueError):
        return None


def rows_from_topics(rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    """:data:`~vilma.scenario.drive_log.COLUMNS` rows at each pose of a live recording (latest value of the
    other topics at that stamp in that epoch; the driver's NaN before their first), from the first pose of
    each epoch at which the plant is known (its velocity and actuators too), and each row's epoch.

    Raises:
        RecordingError: no pose with the plant known.
    """
    pose, epochs = rec.readings("pose"), rec.epoch("pose")
    out = np.full((len(pose), len(COLUMNS)), math.nan)
    out[:, 0] = pose.stamp_ns * 1e-9
    col = COLUMNS.index
    out[:, col("x")], out[:, col("y")], out[:, col("yaw")] = pose.field("x"), pose.field("y"), pose.field("yaw")

    def fill(name: str, stamps: np.ndarray, values: dict[str, np.ndarray]) -> None:
        own = rec.epoch(name)
        for e in np.unique(epochs):
            at, mine = np.flatnonzero(epochs == e), np.flatnonzero(own == e)
            i = np.searchsorted(stamps[mine], pose.stamp_ns[at], side="right") - 1
            ok = i >= 0
            for c, v in values.items():
                out[at[ok], col(c)] = v[mine[i[ok]]]

    v = rec.readings("velocity")
    fill("velocity", v.stamp_ns, {"vx": v.field("vx"), "vy": v.field("vy"), "yaw_rate": v.field("wz")})
    a = rec.readings("actuators")
    fill("actuators", a.stamp_ns, {"steer": a.field("steer"), "drive_force": a.field("drive_force"),
                                   "brake_force": a.field("brake_force")})
    st = rec.messages("driver/status")
    fill("driver/status", np.array([s.stamp_ns for s in st], np.int64),
         {"target_speed": np.array([s.target_speed for s in st]), "measured_speed": np.array([s.speed for s in st])})
    cmd = rec.messages("cmd")
    fill("cmd", np.array([c.stamp_ns for c in cmd], np.int64),
         {"cmd_steer": np.array([c.steer for c in cmd]), "cmd_drive": np.array([c.drive for c in cmd]),
          "cmd_brake": np.array([c.brake for c in cmd])})
    known = np.isfinite(out[:, 1:1 + len(PLANT_COLUMNS)]).all(axis=1)
    started = np.zeros(len(out), bool)
    for e in np.unique(epochs):
        started[epochs == e] = np.logical_or.accumulate(known[epochs == e])
    if not started.any():
        raise RecordingError(f"{rec.path}: no pose with the car's velocity and actuators recorded at it (topics "
                             "velocity and actuators): nothing to score")
    return out[started], epochs[started]


def segments(rows: np.ndarray, epochs: np.ndarray, scenario: Scenario) -> list[tuple[int, int, str]]:
    """The stretches of ``rows`` between resets, as (first row, end row, how it began: ``start``, ``reset`` (the
    sim's clock went back) or ``jump`` (the car moved farther than its speed allows, beyond the pose's noise))."""
    c = COLUMNS.index
    t, x, y = rows[:, 0], rows[:, c("x")], rows[:, c("y")]
    speed = np.hypot(rows[:, c("vx")], rows[:, c("vy")])
    pose = scenario.sim.sensors.pose
    slack = JUMP_SLACK + 8.0 * (pose.position_noise if pose is not None else 0.0)  # 4 sigma on each row
    dt = np.diff(t)
    reach = dt * (np.fmax(speed[:-1], speed[1:]) + MAX_ACCEL * dt) + slack  # NaN (speed unknown): no jump told
    reset = np.diff(epochs) != 0
    cuts = np.flatnonzero(reset | (np.hypot(np.diff(x), np.diff(y)) > reach)) + 1
    bounds = [0, *cuts.tolist(), len(rows)]
    return [(lo, hi, "start" if not lo else "reset" if reset[lo - 1] else "jump")
            for lo, hi in itertools.pairwise(bounds)]


def run_task(rec: Recording, scenario: Scenario, rows: np.ndarray) -> Task:
    """The task of a ``vilma run`` recording: the scenario's, from the run's start (else the first row)."""
    t_start = float(rec.meta("run").get("t_start", rows[0, 0]))
    return _task(0, t_start, scenario.task, path_of(rec, scenario), "the recording holds no path for the run's task")


def live_tasks(rec: Recording, scenario: Scenario) -> list[Task]:
    """The driver's tasks in a live recording, in order: one for each order it took (``driver/cmd``), else for
    each change of its mode (``driver/status``)."""
    status = list(zip(rec.epoch("driver/status").tolist(), rec.messages("driver/status"), strict=True))
    orders = [(e, o) for e, o in zip(rec.epoch("driver/cmd").tolist(), rec.messages("driver/cmd"), strict=True)
              if o.action in TASK_ACTIONS] or _orders_of_modes(rec, scenario, status)
    return [_order_task(e, o, status) for e, o in orders]


def _orders_of_modes(rec: Recording, scenario: Scenario, status: list) -> list[tuple[int, DriverOrder]]:
    """The orders the driver's modes tell, at each change (a recording without the driver's orders); a path
    the scenario's, if its task is one."""
    path = path_of(rec, scenario) if scenario.task.kind in ("follow", "course") else None
    out, mode = [], None
    for e, s in status:
        if s.mode != mode:
            mode = s.mode
            points = path.xy.tolist() if path is not None and mode == "follow" else []
            out.append((e, DriverOrder(stamp_ns=s.stamp_ns, action="go_to" if mode == "go_to_point" else mode,
                                       points=points)))
    return out


def _order_task(epoch: int, order: DriverOrder, status: list) -> Task:
    """The task ``order`` gave; a speed task's speed its own, else the driver's target once it took it."""
    t, a = order.stamp_ns * 1e-9, order.action
    speed = order.speed if math.isfinite(order.speed) else None
    try:
        if a == "manual":
            return Task(epoch, t, None, why="the driver was in manual mode: no task")
        if a in ("set_speed", "hold_speed"):
            if speed is None:
                speed = next((s.target_speed for e, s in status if (e, s.stamp_ns) >= (epoch, order.stamp_ns)
                              and s.mode == a), None)
            return Task(epoch, t, TaskSpec(speed=speed))
        path = Trajectory.from_points(order.points) if len(order.points) > 1 else None
        spec = TaskSpec(go_to=(order.x, order.y), speed=speed) if a == "go_to" else TaskSpec(follow="driver/cmd",
                                                                                             speed=speed)
        return _task(epoch, t, spec, path, f"the driver's {a} order holds no path")
    except ValueError as e:
        return Task(epoch, t, None, why=f"the driver's {a} order: {e}")


def _task(epoch: int, t: float, spec: TaskSpec, path: Trajectory | None, no_path: str) -> Task:
    """The task of ``spec``; not known (``no_path`` says why) if it follows a path the recording lacks."""
    if spec.kind != "speed" and path is None:
        return Task(epoch, t, None, why=no_path)
    return Task(epoch, t, spec, path)


def score_segment(rows: np.ndarray, epoch: int, task: Task, base: Scenario, status: SimStatus | None,
                  collisions: int | None, truncated: bool) -> RunResult:
    """The scorecard of one segment's ``rows`` (clock ``epoch``) with its task, the simulator's last ``status``
    in it and the ``collisions`` of the run (None: the status's)."""
    t0 = float(rows[0, 0])
    t_start = max(task.t_start, t0) if task.epoch == epoch else t0
    scenario = dataclasses.replace(base, task=task.spec or UNKNOWN)
    log = DriveLog(capacity=len(rows) + 1)
    log.extend(rows)
    broke_down = WATCHDOG_STOP if status is not None and status.watchdog_tripped else None
    m = scorecard(log, scenario, task.path, t_start, broke_down, truncated)
    if task.spec is None and m["completed"]:
        m.update(completed=None, incomplete_reason=task.why)
    m["collisions"] = collisions if collisions is not None else status.collisions if status is not None else None
    return RunResult(scenario, m, [], log, task.path, t_start)


class _Cycle(msgspec.Struct):
    """What the planning plot reads of a ``planning/plan`` message (the paths are skipped unread)."""

    stamp_ns: int
    mode: str
    planning_ms: float | None = None


class _Scan(msgspec.Struct):
    """What the perception plot reads of a ``perception/objects`` message."""

    stamp_ns: int
    objects: list[msgspec.Raw] = []


def planning_log(rec: Recording, epoch: int, since_ns: int) -> PlanningLog | None:
    """The planning cycles and the scans' tracks recorded in clock ``epoch`` from ``since_ns`` [ns] on; None if the
    recording holds no plan there."""
    def read(name: str, kind: type) -> list:
        data = [d for d, e in zip(rec.payloads(name), rec.epoch(name).tolist(), strict=True) if e == epoch]
        got = msgspec.json.decode(b"[" + b",".join(data) + b"]", type=list[kind]) if data else []
        return [g for g in got if g.stamp_ns >= since_ns]

    try:
        cycles, scans = read("planning/plan", _Cycle), read("perception/objects", _Scan)
    except msgspec.DecodeError as e:
        raise RecordingError(f"{rec.path}: a planning/plan or perception/objects message is malformed ({e}): "
                             "not written by vilma, or damaged") from None
    if not cycles:
        return None
    return PlanningLog([c.stamp_ns * 1e-9 for c in cycles],
                       [math.nan if c.planning_ms is None else c.planning_ms for c in cycles], [c.mode for c in cycles],
                       [s.stamp_ns * 1e-9 for s in scans], [len(s.objects) for s in scans])


def world_counts(rec: Recording) -> dict[str, int]:
    """Messages of each camera and laser topic (``camera/front_left``: 600, ``laser``: 300...)."""
    return {name: rec.count(name) for name in rec.world_topics}


def score(rec: Recording) -> Report:
    """The report of ``rec`` (see the module docstring), without its files.

    Raises:
        RecordingError: the recording has neither a drive log nor poses with the plant known.
    """
    base = scenario_of(rec)
    rows, epochs = rec.drive_log(), rec.epoch(DRIVE_LOG)
    if len(rows):
        tasks = [run_task(rec, base, rows)]
    elif rec.count("pose"):
        rows, epochs = rows_from_topics(rec)
        tasks = live_tasks(rec, base)
    else:
        raise RecordingError(f"{rec.path}: no drive_log and no pose topic: nothing to score")
    cut_short = not rec.complete or (rec.meta("vilma").get("source") == "vilma run" and "run" not in rec.metadata)
    ran = rec.meta("scorecard")
    status = rec.messages("sim/status")
    status_at = np.array([s.stamp_ns for s in status], np.int64), rec.epoch("sim/status")
    parts, times = [], {}
    for lo, hi, began in segments(rows, epochs, base):
        e, t1 = int(epochs[lo]), rows[hi - 1, 0]
        last = np.flatnonzero((status_at[1] == e) & (status_at[0] <= round(t1 * 1e9)))
        seg = score_segment(rows[lo:hi], e, _task_at(tasks, e, t1), base, status[last[-1]] if len(last) else None,
                            ran.get("collisions"), cut_short and hi == len(rows))
        parts.append({"start_s": float(rows[lo, 0]), "began": began,
                      **{k: v for k, v in seg.metrics.items() if k not in TIMING_KEYS}})
        times[e] = seg.metrics["sim_time_s"]  # an epoch's sim time: its last segment's end
    m = {**seg.metrics, "distance_m": sum(p["distance_m"] for p in parts), "sim_time_s": sum(times.values())}
    m.update(timing(m["sim_time_s"], None, ran.get("loop_wall_time_s"), ran.get("load_time_s")))
    m.update((k, ran[k]) for k in PLANNING_KEYS if k in ran)
    failures = (expectation_failures(m, seg.scenario) if m["completed"] is not None
                else check_expectations(m, seg.scenario.expect))
    return Report(seg.scenario, m, failures, seg.log, seg.path, seg.t_start,
                  planning=planning_log(rec, e, round(rows[lo, 0] * 1e9) if lo else 0), segments=parts)


def _task_at(tasks: list[Task], epoch: int, t: float) -> Task:
    """The task under way at ``t`` [s] of clock ``epoch``: the last one given by then."""
    given = [k for k in tasks if (k.epoch, k.t_start) <= (epoch, t)]
    if given:
        return given[-1]
    return Task(epoch, 0.0, None, why="the driver took no order before this segment" if tasks else
                "the recording holds neither the driver's orders nor its status")


def report_dir(recording: Path) -> Path:
    """Where the report of ``recording`` goes by default: ``<RUN>-report/`` beside it."""
    return recording.with_name(recording.stem + "-report")


def report(recording: Path | Recording, out_dir: Path | None = None) -> Report:
    """Score and plot ``recording`` (a path, or one already read): ``metrics.json`` (the scorecard and its
    ``segments``) and the last segment's plots go to ``out_dir`` (default :func:`report_dir`).

    Raises:
        RecordingError: the file is not a recording, or has nothing to score.
    """
    from vilma.scenario.report import plot_run  # matplotlib only here

    rec = recording if isinstance(recording, Recording) else read_recording(recording)
    result = score(rec)
    result.out_dir = Path(out_dir) if out_dir is not None else report_dir(rec.path)
    result.out_dir.mkdir(parents=True, exist_ok=True)
    plot_run(result, result.out_dir)
    write_atomic(result.out_dir / "metrics.json",
                 json.dumps({**result.metrics, "segments": result.segments}, indent=2) + "\n")
    return result
