"""Many cars side by side (the fleet): each drives and scores exactly as it would alone."""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys

import numpy as np
import pytest

from vilma.app.batch import BUNDLED
from vilma.scenario import fleet, load_scenario
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.runner import run
from vilma.scenario.spec import TIMING_KEYS

SIM_COLUMNS = [i for i, c in enumerate(COLUMNS) if c != "controller_us"]


def _cars():
    ekf = load_scenario(BUNDLED / "course_30kmh_ekf.yaml", {"duration": "20"})
    stanley = load_scenario(BUNDLED / "course_30kmh_stanley.yaml", {"duration": "20"})
    noisy = load_scenario(BUNDLED / "course_30kmh_stanley.yaml",  # steers by a noisy pose: the Python loop
                          {"duration": "10", "sensors.pose": "{position_noise: 0.2}", "seed": "4"})
    return [
        ekf,
        dataclasses.replace(ekf, sim=dataclasses.replace(ekf.sim, seed=ekf.sim.seed + 1)),  # other noise
        stanley,
        load_scenario(BUNDLED / "course_30kmh_stanley.yaml", {"duration": "20", "driver.stanley.gain": "1.0"}),
        load_scenario(BUNDLED / "paper_fig11_speed_10.yaml", {"duration": "8"}),  # a speed task, 10 ms driver
        noisy,
    ]


@pytest.mark.slow
def test_each_car_of_a_fleet_drives_as_it_would_alone(monkeypatch):
    monkeypatch.setattr(fleet, "WAVE", 4)  # two waves
    monkeypatch.setattr(fleet, "THREADS", 2)  # two threads a wave, whatever the machine's cores
    cars = _cars()
    heard = []
    together = fleet.run_fleet(cars, progress=lambda done: heard.append(len(done)))
    assert heard == [4, 6]
    for scenario, got in zip(cars, together, strict=True):
        alone = run(scenario)
        assert got.scenario.sim.seed == scenario.sim.seed
        assert got.log.rows.shape == alone.log.rows.shape
        assert np.array_equal(got.log.rows[:, SIM_COLUMNS], alone.log.rows[:, SIM_COLUMNS], equal_nan=True)
        assert {k: v for k, v in got.metrics.items() if k not in TIMING_KEYS} == \
            {k: v for k, v in alone.metrics.items() if k not in TIMING_KEYS}
    # the seeds were the cars' own: the two EKF cars fused different noise
    assert not np.array_equal(together[0].log.column("est_x"), together[1].log.column("est_x"), equal_nan=True)


def test_a_failing_car_stops_the_fleet_with_its_error(monkeypatch):
    monkeypatch.setattr(fleet, "THREADS", 2)
    blocks = []

    def end(drive, ran, wall):
        blocks.append(drive)
        if len(blocks) == 3:
            raise RuntimeError("this block failed")
        end_as_before(drive, ran, wall)

    end_as_before = fleet.CompiledDrive.end
    monkeypatch.setattr(fleet.CompiledDrive, "end", end)
    car = load_scenario(BUNDLED / "paper_fig11_speed_10.yaml", {"duration": "300"})  # 30,000 periods: 30 blocks
    with pytest.raises(RuntimeError, match="this block failed"):
        fleet.run_fleet([car] * 4)
    assert len(blocks) < 60  # of 120: the other thread stopped too


def test_vilma_run_cars_writes_a_folder_a_car(tmp_path):
    out = tmp_path / "out"
    done = subprocess.run([sys.executable, "-m", "vilma", "run", "course_30kmh_ekf", "--cars", "3", "--out", str(out)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    seed = load_scenario(BUNDLED / "course_30kmh_ekf.yaml").sim.seed
    folders = sorted(out.iterdir())
    assert [f.name for f in folders] == [f"course_30kmh_ekf-seed_{seed + k}" for k in range(3)]
    for f in folders:
        assert sorted(p.name for p in f.iterdir()) == ["metrics.json", "scenario.yaml", "timeseries.csv"]
        assert json.loads((f / "metrics.json").read_text())["completed"]
        assert f"seed: {seed + folders.index(f)}" in (f / "scenario.yaml").read_text()


@pytest.mark.parametrize(("args", "says"), [
    (["--cars", "0"], "--cars: must be a whole number of cars, 1-100000, got 0"),
    (["--cars", "two"], "--cars: expected a whole number, got 'two'"),
    (["--cars", "2", "--realtime", "2"], "--cars drives the cars as fast as it can: drop --realtime"),
])
def test_vilma_run_cars_refuses_bad_values(args, says):
    done = subprocess.run([sys.executable, "-m", "vilma", "run", "course_30kmh_ekf", *args], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2
    assert says in done.stderr
    assert "Traceback" not in done.stderr
