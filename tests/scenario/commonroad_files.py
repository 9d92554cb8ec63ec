"""Writing the CommonRoad files some scenario tests build with commonroad-io."""

from __future__ import annotations

import warnings
from pathlib import Path


def write_commonroad(scenario, planning_problems, out: Path) -> Path:
    """Write ``scenario`` and its ``PlanningProblemSet`` to ``out`` with commonroad-io's own writer; returns ``out``."""
    with warnings.catch_warnings():  # commonroad-io's protobuf writer warns of deprecated calls on import
        warnings.simplefilter("ignore")
        from commonroad.common.file_writer import CommonRoadFileWriter, OverwriteExistingFile

        CommonRoadFileWriter(scenario, planning_problems, author="vilma tests", affiliation="", source="",
                             tags=set()).write_to_file(str(out), OverwriteExistingFile.ALWAYS)
    return out
