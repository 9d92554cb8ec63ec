"""``vilma report RUN.mcap``: the scorecard and the plots of a run from its recording alone.

The recording of a ``vilma run`` holds the runner's row a control period
(``drive_log``), the scenario (``scenario.yaml``), the path driven
(``path.csv``) and when the task began (``run`` metadata): the scorecard is
recomputed from them with :func:`vilma.scenario.metrics.scorecard` and the
plots drawn with :func:`vilma.scenario.report.plot_run`, as the run did. A
live recording (``vilma up --record``) has no ``drive_log``: its rows are
rebuilt from the pose, velocity, actuator and driver topics at each pose.
Collisions are counted by the plant, not in any row: they come from the run's
``scorecard`` metadata, or the last ``sim/status`` of a live recording.
Camera images and laser scans are not scored; :func:`world_counts` counts them.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from vilma.record.reader import Recording, RecordingError, read_recording
from vilma.scenario.drive_log import COLUMNS, DriveLog
from vilma.scenario.fields import load_yaml
from vilma.scenario.metrics import expectation_failures, scorecard
from vilma.scenario.runner import RunResult
from vilma.scenario.spec import Scenario, parse_scenario
from vilma.trajectory import Trajectory


def scenario_of(rec: Recording) -> Scenario:
    """The scenario kept in the recording, or the defaults with an idle task if it has none."""
    text = rec.attachments.get("scenario.yaml", b"task: {speed: 0.0001}").decode()
    data, src = load_yaml(text, f"{rec.path}:scenario.yaml")
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


def rows_from_topics(rec: Recording) -> np.ndarray:
    """:data:`~vilma.scenario.drive_log.COLUMNS` rows at each pose of a live recording (latest value of the
    other topics at that stamp; NaN before their first)."""
    pose = rec.readings("pose")
    out = np.full((len(pose), len(COLUMNS)), math.nan)
    out[:, 0] = pose.stamp_ns * 1e-9
    col = COLUMNS.index
    out[:, col("x")], out[:, col("y")], out[:, col("yaw")] = pose.field("x"), pose.field("y"), pose.field("yaw")

    def fill(name: str, stamps: np.ndarray, values: dict[str, np.ndarray]) -> None:
        if not len(stamps):
            return
        i = np.searchsorted(stamps, pose.stamp_ns, side="right") - 1
        ok = i >= 0
        for c, v in values.items():
            out[ok, col(c)] = v[i[ok]]

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
    return out


def collisions_of(rec: Recording) -> int | None:
    """Collisions of the car with the world's obstacles: the run's scorecard's, else the last simulator status's
    (None if the recording has neither)."""
    if "collisions" in rec.metadata.get("scorecard", {}):
        return rec.meta("scorecard")["collisions"]
    status = rec.messages("sim/status")
    return status[-1].collisions if status else None


def world_counts(rec: Recording) -> dict[str, int]:
    """Messages of each camera and laser topic (``camera/front_left``: 600, ``laser``: 300...)."""
    return {name: rec.count(name) for name in rec.world_topics}


def report(recording: Path | Recording, out_dir: Path | None = None) -> RunResult:
    """Score and plot ``recording`` (a path, or one already read); files (``metrics.json`` and the PNGs) go to
    ``out_dir`` (default ``<RUN>-report/`` beside it).

    Raises:
        RecordingError: the file is not a recording, or has neither a drive log nor poses.
    """
    from vilma.scenario.report import plot_run  # matplotlib only here

    rec = recording if isinstance(recording, Recording) else read_recording(recording)
    path = rec.path
    scenario = scenario_of(rec)
    rows = rec.drive_log()
    if not len(rows):
        if not rec.count("pose"):
            raise RecordingError(f"{path}: no drive_log and no pose topic: nothing to score")
        rows = rows_from_topics(rec)
    log = DriveLog(capacity=len(rows) + 1)
    log.extend(rows)
    run = rec.meta("run")
    t_start = float(run.get("t_start", rows[0, 0]))
    trajectory = path_of(rec, scenario)
    metrics = scorecard(log, scenario, trajectory, t_start)
    metrics["collisions"] = collisions_of(rec)
    failures = expectation_failures(metrics, scenario)
    result = RunResult(scenario, metrics, failures, log, trajectory, t_start)
    out = Path(out_dir) if out_dir is not None else Path(path).with_name(Path(path).stem + "-report")
    out.mkdir(parents=True, exist_ok=True)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n", encoding="utf-8")
    plot_run(result, out)
    result.out_dir = out
    return result
