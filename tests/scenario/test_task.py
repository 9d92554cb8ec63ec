"""The ``task`` section's parameters: the smoothing weights the paper's sweeps converge with."""

from __future__ import annotations

import pytest

from vilma.scenario.fields import SpecError
from vilma.scenario.spec import load_scenario
from vilma.scenario.task import SmoothSpec


def test_smoothing_weights_are_checked_for_the_iterative_sweeps_only(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("task:\n  course: [[0, 0], [10, 0], [20, 5]]\n  speed: 4\n  smooth: {alpha: 0.5, beta: 1}\n")
    with pytest.raises(SpecError, match=r"^.*s\.yaml:4: task\.smooth\.beta: beta must be in \[0, 0\.75\) with "
                                        r"alpha 0\.5"):
        load_scenario(str(path))
    path.write_text("task:\n  course: [[0, 0], [10, 0], [20, 5]]\n  speed: 4\n  smooth: {beta: 1, solver: banded}\n")
    assert load_scenario(str(path)).task.smooth == SmoothSpec(beta=1.0, solver="banded")
