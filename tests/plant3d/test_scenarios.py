"""The paper's scenarios on the 3D plant: they complete, and score within twice the single-track plant's errors."""

from __future__ import annotations

import dataclasses

import pytest

from vilma.app.batch import BUNDLED
from vilma.scenario.runner import run
from vilma.scenario.spec import load_scenario


@pytest.mark.slow
@pytest.mark.parametrize(("name", "metrics"), [
    ("paper_fig12_path", ("lateral_error_rms_m", "lateral_error_max_m", "speed_error_rms_mps")),
    ("paper_fig11_speed_10", ("speed_error_rms_mps", "speed_rise_time_90_s")),
])
def test_paper_scenarios_on_the_3d_plant(name, metrics):
    planar = load_scenario(BUNDLED / f"{name}.yaml")
    plant3d = dataclasses.replace(planar, sim=dataclasses.replace(planar.sim, model="mujoco"))
    a, b = run(planar).metrics, run(plant3d).metrics
    assert b["completed"]
    for m in metrics:
        assert b[m] <= 2 * a[m], (m, a[m], b[m])
