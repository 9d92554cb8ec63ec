"""A run's folder: the files a run writes there, each run's own folder in a batch, and claiming it.

A run writes into a folder of its own and never mixes with an earlier run: a folder that holds anything
is refused unless the user says ``--overwrite``, and then the earlier run's files are removed first.
``metrics.json`` is written last, so a folder with it holds a whole run.
"""

from __future__ import annotations

import shutil
from collections import Counter
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from vilma.scenario.fields import SpecError

if TYPE_CHECKING:
    from vilma.app.batch import Job

PLOTS = ("path.png", "speed.png", "cross_track.png", "effort.png")
"""The plots of a run (:func:`vilma.scenario.report.plot_run`)."""
RECORDING = "run.mcap"
"""The run's recording (:mod:`vilma.record.run`)."""
RUN_FILES = ("metrics.json", "timeseries.csv", "timeseries.csv.part", "scenario.yaml", RECORDING, *PLOTS)
"""The files a run writes in its folder."""
REPORT_DIR = "run-report"
"""Where ``vilma report`` puts the report of the folder's recording."""


def out_dirs(jobs: Sequence[Job], out: Path | None) -> list[Path]:
    """Each run's folder: ``out`` for a single run, else ``<out>/<name>`` (``runs/<name>-<timestamp>``
    without ``out``); a name is the scenario's, its ``--set`` values, and where two runs would still share
    it, the scenario file's folder, then ``-2``, ``-3``..."""
    if out is not None and len(jobs) == 1:
        return [out]
    names = [job.scenario.name + "".join(f"-{k}_{v}" for k, v in job.overrides) for job in jobs]
    files: dict[str, set] = {}
    for job, n in zip(jobs, names, strict=True):
        files.setdefault(n, set()).add(job.scenario.file)
    names = [f"{job.scenario.file.parent.name}-{n}" if len(files[n]) > 1 and job.scenario.file else n
             for job, n in zip(jobs, names, strict=True)]
    seen: Counter[str] = Counter()
    unique = []
    for n in names:
        seen[n] += 1
        unique.append(n if seen[n] == 1 else f"{n}-{seen[n]}")
    if out is None:
        stamp = datetime.now().strftime("%Y%m%d-%H%M%S-%f")
        return [Path("runs") / f"{n}-{stamp}" for n in unique]
    return [out / n for n in unique]


def claim(dirs: Sequence[Path], overwrite: bool) -> None:
    """Check that no run's folder holds anything; with ``overwrite``, remove the earlier run's files
    (:data:`RUN_FILES` and its report), leaving anything else there as it is.

    Raises:
        SpecError: a folder holds files and ``overwrite`` is not given; one line naming it.
    """
    for d in dirs:
        if d.exists() and not d.is_dir():
            raise SpecError(f"{d}: is a file, not a folder; choose another --out")
        held = sorted(p.name for p in d.iterdir()) if d.is_dir() else []
        if held and not overwrite:
            shown = ", ".join(held[:4]) + (", ..." if len(held) > 4 else "")
            raise SpecError(f"{d}: holds an earlier run or other files ({shown}); give --overwrite to replace the "
                            "run's files, or choose another --out")
        for name in held:
            if name in RUN_FILES:
                (d / name).unlink()
            elif name == REPORT_DIR and (d / name).is_dir():
                shutil.rmtree(d / name)
