"""A run's folder: the files a run writes there (a CommonRoad run's ``solution.xml`` too), each run's own folder
in a batch, and claiming it.

A run writes into a folder of its own and never mixes with an earlier run: a folder that holds anything
is refused unless the user says ``--overwrite``, and then the earlier run's files are removed first.
``metrics.json`` is written last, so a folder with it holds a whole run.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from vilma.core.files import write_atomic
from vilma.scenario.drive_log import DriveLog, TimeseriesWriter
from vilma.scenario.fields import SpecError
from vilma.scenario.result import RunObserver, RunResult
from vilma.scenario.spec import Scenario, beside, to_yaml
from vilma.sim import Simulator
from vilma.trajectory import load_speed_log

PLOTS = ("path.png", "speed.png", "cross_track.png", "effort.png")
"""The plots of a run (:func:`vilma.scenario.report.plot_run`)."""
PLANNING_PLOTS = ("planning.png", "perception.png")
"""The plots of a planned run besides :data:`PLOTS`."""
RECORDING = "run.mcap"
"""The run's recording (:mod:`vilma.record.run`)."""
SOLUTION = "solution.xml"
"""A CommonRoad run's drive as the benchmark's solution file (:mod:`vilma.world.solution`)."""
RUN_FILES = ("metrics.json", "timeseries.csv", "timeseries.csv.part", "scenario.yaml", RECORDING, SOLUTION, *PLOTS,
             *PLANNING_PLOTS)
"""The files a run writes in its folder."""
REPORT_DIR = "run-report"
"""Where ``vilma report`` puts the report of the folder's recording."""
NAME_BYTES = 200
"""Longest folder name :func:`folder_name` gives [bytes of UTF-8]: room under a file system's 255 for the
``-<timestamp>`` and ``-2`` a run's folder may get."""


def folder_name(text: str) -> str:
    """``text`` (a scenario's name and ``--set`` values) as one folder name that stays where it is put: each run of
    characters other than letters, digits and ``._+=,-`` made ``_`` (no ``/``, no control characters), no ``.``,
    ``_`` or ``-`` at either end (never hidden, never ``..``), at most :data:`NAME_BYTES`; ``run`` if nothing is
    left."""
    name = re.sub(r"[^\w.+=,-]+", "_", text).strip("._-")
    name = name.encode()[:NAME_BYTES].decode(errors="ignore").rstrip("._-")
    return name or "run"


def claim(dirs: Sequence[Path], overwrite: bool, clear_now: bool = True) -> None:
    """Check that each folder can be made and written, and that none holds anything; with ``overwrite``, remove the
    earlier run's files (:func:`clear`), unless not ``clear_now`` (a batch clears each run's folder as the run
    starts: one interrupted keeps the earlier files of the runs it did not reach).

    Raises:
        SpecError: a folder (or the one it would be made in) is a file or cannot be written, or a folder holds files
            and ``overwrite`` is not given; one line naming it.
    """
    for d in dirs:
        base = next(p for p in (d, *d.parents) if p.exists())  # the folder itself, or where it would be made
        where = "it" if base == d else base
        if not base.is_dir():
            raise SpecError(f"{d}: {where} is a file, not a folder; choose another --out")
        if not os.access(base, os.W_OK | os.X_OK | (os.R_OK if base == d else 0)):
            raise SpecError(f"{d}: cannot write in {where} (no permission, or a read-only disk); choose another --out")
        held = sorted(p.name for p in d.iterdir()) if d.is_dir() else []
        if held and not overwrite:
            shown = ", ".join(held[:4]) + (", ..." if len(held) > 4 else "")
            raise SpecError(f"{d}: holds an earlier run or other files ({shown}); give --overwrite to replace the "
                            "run's files, or choose another --out")
        if clear_now:
            clear(d)


def clear(d: Path) -> None:
    """Remove the earlier run's files from the folder ``d`` (:data:`RUN_FILES` and its report), leaving anything else
    there as it is (nothing if ``d`` does not exist)."""
    for p in d.iterdir() if d.is_dir() else ():
        if p.name in RUN_FILES:
            p.unlink()
        elif p.name == REPORT_DIR and p.is_dir():
            shutil.rmtree(p)


class RunFolder(RunObserver):
    """Writes a run's folder as it goes: ``timeseries.csv`` streamed, then ``scenario.yaml`` and the plots (unless
    ``plots`` is False; :func:`write_metrics` comes last, from whoever ran it: a folder with ``metrics.json``
    holds a whole run)."""

    def __init__(self, out_dir: Path, plots: bool = True) -> None:
        self.out_dir, self.plots = out_dir, plots
        self.series: TimeseriesWriter | None = None

    def started(self, sim: Simulator, log: DriveLog) -> None:
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.series = TimeseriesWriter(self.out_dir / "timeseries.csv", sim.sensors, log)

    def add(self, readings) -> None:
        self.series.add(readings)

    def finished(self, result: RunResult) -> None:
        self.series.close()
        write_atomic(self.out_dir / "scenario.yaml", to_yaml(result.scenario))
        if result.scenario.road is not None:
            write_atomic(self.out_dir / SOLUTION, solution(result))
        if self.plots:
            from vilma.scenario.report import plot_run  # matplotlib (a second to import) only once there is a plot

            plot_run(result, self.out_dir, speed_log(result.scenario))
        result.out_dir = self.out_dir

    def failed(self, interrupted: bool) -> None:
        if self.series is not None:  # Ctrl-C keeps the timeseries so far; an error marks it unfinished
            self.series.close() if interrupted else self.series.abort()


def solution(result: RunResult) -> str:
    """The text of a CommonRoad run's ``solution.xml``."""
    from vilma.world.solution import solution_xml  # the roads extra, there when the scenario is a road

    c = result.log.column
    return solution_xml(result.scenario.road, result.scenario.sim.vehicle.name, c("t"), c("x"), c("y"), c("yaw"),
                        c("vx"), c("vy"), c("yaw_rate"), c("steer"))


def write_metrics(result: RunResult, out_dir: Path) -> Path:
    """``metrics.json``: the scorecard."""
    return write_atomic(out_dir / "metrics.json", json.dumps(result.metrics, indent=2) + "\n")


def speed_log(scenario: Scenario) -> tuple[np.ndarray, np.ndarray] | None:
    """The recorded speed log the scenario compares with (``speed_log`` beside the scenario), or None."""
    if scenario.speed_log is None:
        return None
    p = beside(scenario.file, scenario.speed_log)
    try:
        return load_speed_log(p)
    except (OSError, ValueError) as e:
        raise SpecError(f"{scenario.file or scenario.name}: speed_log: cannot read {p}: {e}") from None
