"""A controller registered from outside vilma drives through the Driver, the compiled loop and scenario files,
with no edit to any of them."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest
from numba import njit
from numba.core.caching import NullCache

from vilma.control import registry
from vilma.control.driver import Driver, DriverParams, driver_step
from vilma.control.registry import PATH, ControllerType, register
from vilma.control.speed.pi_ff import PiFfParams
from vilma.scenario import load_scenario
from vilma.scenario.drive_log import COLUMNS
from vilma.scenario.lockstep import _loop
from vilma.scenario.runner import run
from vilma.sim import SimConfig, Simulator
from vilma.trajectory import Trajectory
from vilma.vehicle.params import vilma

STEER = 0.1
"""The throwaway controller's front-wheel angle [rad]."""


@dataclass(frozen=True, slots=True, kw_only=True)
class ConstantSteerParams:
    period: float = 0.02
    steer: float = 0.0


class ConstantSteerConsts(NamedTuple):
    steer: float


class OtherConsts(NamedTuple):
    steer: float


@njit
def constant_steer_step(c, st, pa, x, y, yaw, speed, yaw_rate):
    st[0] += 1.0  # periods stepped: the state is the controller's
    return c.steer, False


CONSTANT_STEER = register(ControllerType("test_constant_steer", PATH, ConstantSteerParams, ConstantSteerConsts,
                                         lambda p, vehicle: ConstantSteerConsts(p.steer), (0.0,), constant_steer_step))


@pytest.fixture(autouse=True)
def _compiled_for_this_process_only(monkeypatch):
    """Keep the test's constants type out of the on-disk numba cache: an index naming a class of ``tests`` would
    fail to load wherever ``tests`` is not importable (the installed ``vilma`` command)."""
    for dispatcher in (driver_step, _loop):
        monkeypatch.setattr(dispatcher, "_cache", NullCache())


def _params() -> DriverParams:
    return DriverParams(path_controller="test_constant_steer", gains={"test_constant_steer": ConstantSteerParams(
        steer=STEER)})


def test_the_registry_lists_it_and_refuses_a_second_of_that_name():
    assert "test_constant_steer" in registry.names(PATH) and "test_constant_steer" not in registry.names("speed")
    assert registry.controller_type("test_constant_steer") is CONSTANT_STEER
    with pytest.raises(ValueError, match="'test_constant_steer' is registered already"):
        register(CONSTANT_STEER)
    with pytest.raises(ValueError, match="speed controller 'test_constant_steer' is unknown; use one of pi_ff"):
        registry.controller_type("test_constant_steer", "speed")
    with pytest.raises(ValueError, match="driver speed_controller: speed controller 'test_constant_steer' is unknown"):
        DriverParams(speed_controller="test_constant_steer")
    with pytest.raises(ValueError, match="driver gains of stanley: expected StanleyParams, got PiFfParams"):
        DriverParams(gains={"stanley": PiFfParams()})


def test_vilma_controllers_load_on_first_use_and_keep_their_names():
    """Each module of :data:`~vilma.control.registry.BUNDLED` is the controller of its name: listed before it is
    imported, imported when asked for, and its name taken from the start."""
    code = ("import json, sys\nfrom vilma.control import registry\n"
            "listed = registry.names()\nbefore = 'vilma.control.path.lqr' in sys.modules\n"
            "lqr = registry.controller_type('lqr', 'path')\n"
            "print(json.dumps([listed, before, lqr.name, 'vilma.control.path.pure_pursuit' in sys.modules]))")
    out = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    control = Path(registry.__file__).parent  # each module of its speed/ and path/ is the controller of its name
    files = sorted(p.stem for kind in ("speed", "path") for p in (control / kind).glob("[!_]*.py"))
    assert out == [files, False, "lqr", False]
    with pytest.raises(ValueError, match="'pure_pursuit' is registered already"):
        register(ControllerType("pure_pursuit", PATH, ConstantSteerParams, OtherConsts,
                                lambda p, vehicle: OtherConsts(0.0), (0.0,), constant_steer_step))


def test_the_driver_steers_with_it():
    sim = Simulator(SimConfig())
    d = Driver(sim.config.vehicle, _params(), step=sim.config.step)
    d.update(sim.advance(d.period_ticks))
    d.follow(Trajectory.from_points([(0.0, 0.0), (100.0, 0.0)]), 3.0)
    commands = [d.update(sim.advance(d.period_ticks)) for _ in range(10)]
    assert all(c.steer == STEER for c in commands)
    # the path controller runs every 20 ms, the driver every 20 ms (gcd with pi_ff's 40 ms): once a period
    assert d.period == pytest.approx(0.02) and d.path_ctrl.state[0] == 10.0


def test_scenario_files_name_it_and_the_compiled_loop_drives_it_as_the_python_loop(tmp_path):
    (tmp_path / "s.yaml").write_text("task: {go_to: [60, 0], speed: 3}\nplant: kinematic\nduration: 20\n"
                                     f"path_controller: {{type: test_constant_steer, steer: {STEER}}}\n",
                                     encoding="utf-8")
    s = load_scenario(tmp_path / "s.yaml")
    assert s.driver.path_controller == "test_constant_steer" and s.driver.gains_of("test_constant_steer").steer == STEER
    compiled, python = run(s, compiled=True), run(s, compiled=False)
    rows = compiled.log.rows
    timing = COLUMNS.index("controller_us")
    keep = [i for i in range(len(COLUMNS)) if i != timing]
    assert np.array_equal(rows[:, keep], python.log.rows[:, keep], equal_nan=True)
    steer = rows[:, COLUMNS.index("cmd_steer")]
    assert np.all(steer[~np.isnan(steer)] == STEER) and (~np.isnan(steer)).sum() > 100
    # a kinematic car at a constant front-wheel angle turns at v tan(delta) / L
    v, yaw_rate = rows[-1, COLUMNS.index("vx")], rows[-1, COLUMNS.index("yaw_rate")]
    assert yaw_rate == pytest.approx(v * math.tan(STEER) / vilma().wheelbase, rel=1e-6)
