"""The EKF fused inside the compiled loop ends exactly where the Python estimator ends, and the sensors too."""

from __future__ import annotations

import numpy as np

from vilma.app.batch import BUNDLED
from vilma.control.driver import Driver
from vilma.localization import Ekf
from vilma.scenario import load_scenario
from vilma.scenario.drive_log import DriveLog
from vilma.scenario.lockstep import run_compiled
from vilma.scenario.lockstep_ekf import ekf_ok
from vilma.scenario.runner import initial_state, start_task
from vilma.sim import Simulator

PERIODS = 300
"""Driver periods of each drive: more than a block (256), so the state crosses a block's end."""


def _drive(compiled: bool) -> tuple[Simulator, Driver, dict]:
    """The EKF course for ``PERIODS`` periods after the first; also the readings of one more period."""
    s = load_scenario(BUNDLED / "course_30kmh_ekf.yaml")
    path = s.reference_path()
    sim, driver = Simulator(s.sim), Driver(s.sim.vehicle, s.driver, step=s.sim.step)
    sim.reset(initial_state(s, path))
    driver.update(sim.advance(driver.period_ticks))
    start_task(driver, s, path)
    if compiled:
        run_compiled(sim, driver, DriveLog(capacity=PERIODS), PERIODS, False)
    else:
        for _ in range(PERIODS):
            cmd = driver.update(sim.advance(driver.period_ticks))
            if cmd is not None:
                sim.command(cmd)
    return sim, driver, sim.advance(driver.period_ticks)


def test_estimator_sensors_and_plant_end_alike():
    (sim_c, drv_c, next_c), (sim_p, drv_p, next_p) = _drive(True), _drive(False)
    ekf_c, ekf_p = drv_c.estimator, drv_p.estimator
    assert isinstance(ekf_c, Ekf)
    assert np.array_equal(ekf_c.state, ekf_p.state)
    assert np.array_equal(ekf_c.covariance, ekf_p.covariance)
    assert ekf_c.estimate is not None and ekf_c.estimate == ekf_p.estimate
    assert drv_c.stamp_ns == drv_p.stamp_ns == ekf_p.estimate.stamp_ns
    assert sim_c.plant == sim_p.plant
    # the loop measured from copies of the sensors' noise: the simulator's own generators went on as in Python
    assert next_c.keys() == next_p.keys()
    for name in next_p:
        assert np.array_equal(next_c[name].values, next_p[name].values), name


def test_ekf_needs_its_three_sensors():
    s = load_scenario(BUNDLED / "course_30kmh_ekf.yaml")
    assert ekf_ok(Simulator(s.sim))
    for sensor in ("imu", "wheel_speed", "gps"):
        without = load_scenario(BUNDLED / "course_30kmh_ekf.yaml", {f"sensors.{sensor}": "null"})
        assert not ekf_ok(Simulator(without.sim)), sensor
