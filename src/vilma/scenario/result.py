"""A run's data, below both the runner that makes it and whatever keeps it (files, recordings, live views):
the finished run, and what watches a run as it goes."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from vilma.scenario.drive_log import DriveLog
from vilma.scenario.spec import Scenario
from vilma.trajectory import Trajectory

if TYPE_CHECKING:  # annotations only: observers are handed the simulator, never build one
    from vilma.core.messages import Message
    from vilma.sensors import Readings
    from vilma.sim import Simulator


@dataclass
class PlanningLog:
    """A planned drive's perception and planning over time (for its plots): each planning cycle's sim time [s],
    wall time [ms] and mode (``velocity``, ``follow``, ``stop`` or ``fallback``), and each scan's sim time [s] and
    number of tracks. A few numbers a cycle and a scan, as the drive log keeps a row a period."""

    cycle_t: list[float] = field(default_factory=list)
    cycle_ms: list[float] = field(default_factory=list)
    modes: list[str] = field(default_factory=list)
    scan_t: list[float] = field(default_factory=list)
    tracks: list[int] = field(default_factory=list)


@dataclass
class RunResult:
    """A finished run: the scenario, the scorecard and what it failed, the log, where the files are."""

    scenario: Scenario
    metrics: dict
    failures: list[str]
    log: DriveLog
    path: Trajectory | None
    """The reference path (for a go-to task: the straight line the driver took)."""
    t_start: float
    """Sim time the task began [s]."""
    out_dir: Path | None = None
    planning: PlanningLog | None = None
    """A plan task's perception and planning over time."""

    @property
    def passed(self) -> bool:
        """Whether the run met its ``expect`` block (and finished its task)."""
        return not self.failures


class RunObserver:
    """Watches a run as it goes (the run's folder, its recording, a live view); every method does nothing here.

    The runner calls :meth:`started` once, then :meth:`add` after each block or period of log rows and
    :meth:`add_captures` with the 3D plant's images and scans and a planned car's tracks and plans; at the end
    either :meth:`finished` then :meth:`close`, or, if the run failed or was interrupted, :meth:`failed` alone.
    """

    def started(self, sim: Simulator, log: DriveLog) -> None:
        """The run's simulator (its sensors) and log, before the first period."""

    def add(self, readings: dict[str, Readings]) -> None:
        """The sensor readings of a block or period, after its rows went into the log."""

    def add_captures(self, captures: list[tuple[str, Message]]) -> None:
        """Camera images and laser scans of a block or period, and a planned car's tracks (``perception/objects``)
        and plans (``planning/plan``), by topic name (never kept by the runner)."""

    def finished(self, result: RunResult) -> None:
        """The run is over and scored (its timing keys so far)."""

    def close(self) -> None:
        """After every observer's :meth:`finished`: wait for work still under way."""

    def failed(self, interrupted: bool) -> None:
        """The run stopped on an error, or on Ctrl-C if ``interrupted``: keep what was made. May come
        before :meth:`started`."""


class OnReadings(RunObserver):
    """An observer that hands each block's readings to a function."""

    def __init__(self, fn: Callable[[dict[str, Readings]], None]) -> None:
        self.fn = fn

    def add(self, readings: dict[str, Readings]) -> None:
        self.fn(readings)
