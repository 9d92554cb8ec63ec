"""The main window: Car Status, the link state, menus (scenarios, reset, about), and the README screenshots."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PySide6.QtCore import Qt

from tests.gui.conftest import SPEED, WAIT_MS, shown_window, speed_of
from vilma.app.batch import find_scenario
from vilma.gui.backend import Embedded
from vilma.scenario.spec import load_scenario
from vilma.trajectory import Trajectory


def test_car_status_shows_the_latest_readings_consistently(window, qtbot, embedded):
    window.auto_dock.speed_edit.setText("3")
    window.auto_dock.set_speed.click()
    window.manual_dock.wheel.blockSignals(True)
    qtbot.waitUntil(lambda: speed_of(window) > 2.0, timeout=WAIT_MS)
    embedded.stop()  # freeze the car so labels and messages can be compared
    dock = window.status_dock
    dock.refresh()
    latest = window.bridge.latest
    p, v, g, w = latest["pose"], latest["velocity"], latest["gps"], latest["wheel_speed"]
    assert float(dock.value("pose.x")) == pytest.approx(p.x, abs=5e-4)
    assert float(dock.value("pose.qz")) == pytest.approx(math.sin(p.yaw / 2), abs=1e-3)  # yaw-only rotation
    assert float(dock.value("pose.qw")) == pytest.approx(math.cos(p.yaw / 2), abs=1e-3)
    assert float(dock.value("vel.speed")) == pytest.approx(math.hypot(v.vx_world, v.vy_world), abs=1e-3)
    assert len(dock.value("gps.lat").split(".")[1]) == 9  # 9 decimals as the original
    assert float(dock.value("gps.x")) == pytest.approx(g.x, abs=5e-4)
    # rolling without slip: wheel speed = speed / wheel radius
    r = embedded.vehicle.wheel_radius
    assert float(dock.value("wheel.rl")) == pytest.approx(w.rl, abs=5e-4)
    assert w.rl == pytest.approx(v.vx / r, rel=0.05)
    assert float(dock.value("imu.az")) == pytest.approx(9.81, abs=0.5)  # specific force holds up against gravity
    assert float(dock.value("sim.time")) == pytest.approx(latest["sim/status"].stamp_ns * 1e-9, abs=0.01)
    assert dock.value("sim.watchdog") == "ok" and dock.value("driver.mode") == "set_speed"
    dock.set_interval(500)
    assert dock.timer.interval() == 500
    with pytest.raises(ValueError, match="refresh"):
        dock.set_interval(1)


def test_losing_the_simulation_shows_disconnected_and_it_reconnects(window, qtbot, embedded):
    assert window.link.text() == "connected"
    embedded.stop()
    qtbot.waitUntil(lambda: window.link.text().startswith("DISCONNECTED"), timeout=WAIT_MS)
    assert window.status_dock.value("sim.link") in ("connected", "DISCONNECTED")
    window.status_dock.refresh()
    assert window.status_dock.value("sim.link") == "DISCONNECTED"
    embedded.start()
    qtbot.waitUntil(lambda: window.link.text() == "connected", timeout=WAIT_MS)


def test_reset_brings_the_car_back_to_the_start(window, qtbot):
    window.auto_dock.speed_edit.setText("4")
    window.auto_dock.set_speed.click()
    qtbot.waitUntil(lambda: window.bridge.latest["pose"].x > 2.0, timeout=WAIT_MS)
    window.reset_simulation()
    qtbot.waitUntil(lambda: window.bridge.latest["pose"].stamp_ns < 1e9, timeout=WAIT_MS)
    assert abs(window.bridge.latest["pose"].x) < 0.5 and not window.auto_dock.set_speed.isChecked()
    assert window.bridge.history["path"].view()[0, 0] < 1.0  # the plot history restarted with the run


def test_scenarios_open_into_the_table_and_save_back(window, tmp_path):
    sc = load_scenario(find_scenario("course_10kmh_pure_pursuit"))
    assert window.open_scenario(find_scenario("course_10kmh_pure_pursuit"))
    np.testing.assert_array_equal(window.table.model.trajectory().xy, sc.reference_path().xy)
    assert window.auto_dock.path_ctrl.currentText() == "pure_pursuit"
    assert float(window.auto_dock.path_speed.text()) == pytest.approx(sc.task.speed)
    window.table.model.set_trajectory(Trajectory.from_points([(0, 0), (10, 0), (20, 5)]))
    out = tmp_path / "mine.yaml"
    assert window.save_scenario(out)
    back = load_scenario(out)
    assert back.task.course == ((0, 0), (10, 0), (20, 5)) and back.driver.path_controller == "pure_pursuit"
    assert back.task.speed == sc.task.speed
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\ntask: {speed: -1}\n")
    assert not window.open_scenario(bad) and "speed" in window.last_message
    assert "vilma" in window.about_text() and "embedded" in window.about_text()


@pytest.mark.parametrize("name", ["course_30kmh_stanley", "course_3d_obstacles"])
def test_a_scenario_given_at_start_arms_its_task_with_its_own_speed(qtbot, tmp_path, name):
    from vilma.gui.main_window import MainWindow

    sc = load_scenario(find_scenario(name))
    backend = Embedded(sc, speed=SPEED)
    try:
        w = MainWindow(backend, record_dir=tmp_path)
        qtbot.addWidget(w)
        order = w.auto_dock.path_order()  # what "Set Wheel Direction" would send
        assert order.action == "follow" and order.speed == pytest.approx(sc.task.speed)
        np.testing.assert_allclose(order.points, sc.reference_path().xy)
        w.close()
    finally:
        backend.close()


@pytest.fixture
def fig12(qtbot, tmp_path):
    backend = Embedded(load_scenario(find_scenario("paper_fig12_path")), speed=8.0)
    w = shown_window(qtbot, backend, tmp_path)
    yield w
    w.close()
    backend.close()


@pytest.mark.slow
def test_screenshots_of_the_main_window_and_the_plots_after_a_drive(fig12, qtbot, screenshots):
    w = fig12
    path = w.backend.scenario.reference_path()
    np.testing.assert_array_equal(w.table.model.trajectory().xy, path.xy)  # the scenario's path fills the table
    w.auto_dock.from_table.setChecked(True)
    w.auto_dock.path_speed.setText("8")
    w.show_plots()
    qtbot.mouseClick(w.auto_dock.wheel_direction, Qt.MouseButton.LeftButton)
    qtbot.waitUntil(lambda: w.bridge.latest["driver/status"].arrived and speed_of(w) < 0.05, timeout=2 * WAIT_MS)
    pose = w.bridge.latest["pose"]
    assert math.hypot(pose.x - path.xy[-1, 0], pose.y - path.xy[-1, 1]) < 1.5
    w.status_dock.refresh()
    w.plots.refresh(force=True)
    assert len(w.plots.car_curve.xData) > 100
    assert w.grab().save(str(screenshots / "gui-main.png"))
    assert w.plots.export_png(screenshots / "gui-plots.png")
    for name in ("gui-main.png", "gui-plots.png"):
        assert (screenshots / name).stat().st_size > 20_000
