"""``run.mcap`` of a ``vilma run``: every sensor reading, the runner's row a control period, the scenario and
the scorecard.

The runner hands over each block of readings (the compiled loop's blocks, or
the Python loop's periods, gathered ``BLOCK`` periods or ``HAND_OVER_S`` at a
time, a sensor's joined as they are copied into shared memory) and the log's
new rows; a recorder in a process of its own (:mod:`vilma.record.process`)
packs and compresses them on another core, and finishes the file even if the
run is killed (a short unpaced run packs them in its own process: :data:`HERE_MAX_S`). The 3D plant's camera
images and laser scans are written as they come (:meth:`RunRecorder.add_captures`). ``run`` metadata and the
``scenario.yaml``, ``path.csv`` and ``metrics.json`` attachments let
``vilma report RUN.mcap`` score the run from the recording alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from vilma.scenario.folder import RECORDING, RunFolder, write_metrics
from vilma.scenario.result import RunObserver, RunResult
from vilma.scenario.runner import Interrupted, run
from vilma.scenario.spec import Scenario

RUN_FILE = RECORDING
"""The recording's name in a run's output folder."""
HERE_MAX_S = 600.0
"""An unpaced run that may last at most this [s of sim time] is recorded in the run's process
(:class:`~vilma.record.process.RecorderHere`): a second interpreter starts in about 0.8 s, more than packing such a
drive takes (``vilma run course_30kmh_stanley``: 1.5 s here against 2.4 s beside; a one-hour drive packs
faster beside its loop: 3.2 s against 4.0 s). A paced run always records beside its loop, which keeps its pace."""


def record_run(scenario: Scenario, out_dir: Path | str, *, record: bool = True, plots: bool = True,
               realtime: float | None = None, compiled: bool = True, observers: Sequence[RunObserver] = (),
               started: float | None = None) -> RunResult:
    """Run ``scenario`` (:func:`~vilma.scenario.runner.run`) writing its folder ``out_dir`` as it goes: the
    timeseries, the recording ``run.mcap`` (unless ``record`` is False), ``scenario.yaml`` and the plots (unless
    ``plots`` is False), then ``metrics.json`` last. The other ``observers`` watch it too (a live view).

    Raises:
        SpecError: the scenario's files cannot be used.
        Interrupted: Ctrl-C; the files so far are kept, the recording finished.
        KeyboardInterrupt: Ctrl-C once the drive was over, while its files were written (the same, no metrics.json).
    """
    out_dir = Path(out_dir)
    mine: list[RunObserver] = []
    if record:
        from vilma.record.run_recorder import RunRecorder  # MCAP and the recording process: only to record

        mine.append(RunRecorder(out_dir / RUN_FILE, scenario, realtime is None and scenario.duration <= HERE_MAX_S))
    try:
        result = run(scenario, realtime, compiled, [*mine, RunFolder(out_dir, plots), *observers], started)
        write_metrics(result, out_dir)  # last: a folder with metrics.json holds a whole run
    except Interrupted as e:
        raise Interrupted(e.t, out_dir) from None
    except KeyboardInterrupt:  # once the drive was over
        raise KeyboardInterrupt(f"interrupted while writing the run's files: partial files in {out_dir}") from None
    return result
