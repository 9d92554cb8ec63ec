"""Automatic Driving against the embedded simulator: file, smoothing, points, speed, path, controllers."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pyqtgraph.exporters import ImageExporter
from PySide6.QtCore import Qt

from tests.gui.conftest import WAIT_MS, speed_of
from vilma.scenario import load_scenario
from vilma.scenario.bundled import find_scenario
from vilma.trajectory import Trajectory, increase_point_count, load_trajectory, smooth_iterative


def _click(qtbot, button) -> None:
    qtbot.mouseClick(button, Qt.MouseButton.LeftButton)


def _type(qtbot, edit, text: str) -> None:
    edit.clear()
    qtbot.keyClicks(edit, text)


def test_input_from_file_fills_the_table_and_a_bad_file_is_refused(window, tmp_path):
    good = tmp_path / "PositionLog.txt"
    good.write_text("-0.35\t16.8\n-0.5 20.1\n-0.9\t30.4\n-1.64\t47.2\n")
    dock = window.auto_dock
    assert dock.load_file(good)
    assert np.array_equal(window.table.model.trajectory().xy, load_trajectory(good).xy)
    assert dock.from_table.isChecked()
    bad = tmp_path / "bad.txt"
    bad.write_text("1 2\n3 x\n")
    assert not dock.load_file(bad)
    assert "bad.txt:2" in window.last_message and "not a number" in window.last_message
    assert len(window.table.model.trajectory()) == 4  # unchanged


def test_smooth_trajectory_gives_what_vilma_trajectory_computes(window, qtbot):
    rng = np.random.default_rng(3)
    xy = np.column_stack([np.arange(12.0) * 2.0, rng.normal(0.0, 0.8, 12)])
    window.table.model.set_trajectory(Trajectory(xy))
    dock = window.auto_dock
    _type(qtbot, dock.alpha_edit, "0.4")
    _type(qtbot, dock.beta_edit, "0.2")
    _type(qtbot, dock.tolerance_edit, "1e-8")
    _click(qtbot, dock.buttons["Smooth Trajectory"])
    np.testing.assert_array_equal(window.table.model.trajectory().xy, smooth_iterative(xy, 0.4, 0.2, 1e-8))
    _type(qtbot, dock.alpha_edit, "zero")
    _click(qtbot, dock.buttons["Smooth Trajectory"])
    assert "alpha" in window.last_message and "not a number" in window.last_message
    _type(qtbot, dock.alpha_edit, "0.9")
    _type(qtbot, dock.beta_edit, "0.6")
    _click(qtbot, dock.buttons["Smooth Trajectory"])
    assert "never settle" in window.last_message


def test_generate_points_doubles_the_intervals(window, qtbot):
    path = Trajectory.from_points([(0, 0), (10, 0), (10, 10), (0, 20)])
    window.table.model.set_trajectory(path)
    _click(qtbot, window.auto_dock.buttons["Generate Points"])
    out = window.table.model.trajectory()
    assert len(out) - 1 == 2 * (len(path) - 1)
    np.testing.assert_array_equal(out.xy, increase_point_count(path).xy)
    window.table.model.set_trajectory(Trajectory.from_points([(1, 1)]))
    _click(qtbot, window.auto_dock.buttons["Generate Points"])
    assert "at least 2 points" in window.last_message


def test_set_speed_brings_the_car_to_the_typed_speed_and_current_speed_excludes_it(window, qtbot):
    dock = window.auto_dock
    target = 4.0
    _type(qtbot, dock.speed_edit, f"{target:g}")
    _click(qtbot, dock.set_speed)
    assert dock.set_speed.isChecked() and not dock.speed_edit.isEnabled()
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].mode == "set_speed", timeout=WAIT_MS)

    def settled() -> bool:
        h = window.bridge.history["speed"].view()
        recent = h[h[:, 0] > h[-1, 0] - 2.0, 1]  # the last 2 s of sim time
        return h[-1, 0] > 2.0 and np.all(np.abs(recent - target) < 0.02 * target)  # within 2 % for 2 s
    qtbot.waitUntil(settled, timeout=WAIT_MS)
    assert window.bridge.latest["driver/status"].target_speed == target
    _click(qtbot, dock.current_speed)  # the toggles exclude each other
    assert dock.current_speed.isChecked() and not dock.set_speed.isChecked() and dock.speed_edit.isEnabled()
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].mode == "hold_speed", timeout=WAIT_MS)
    held = window.bridge.latest["driver/status"].target_speed
    assert abs(held - target) < 0.02 * target  # it holds the speed it had
    _click(qtbot, dock.current_speed)
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].mode == "manual", timeout=WAIT_MS)


@pytest.mark.parametrize("text", ["fast", "", "-2", "1e400", "nan"])
def test_a_bad_set_speed_is_refused_with_a_message_and_no_order(window, qtbot, text):
    dock = window.auto_dock
    _type(qtbot, dock.speed_edit, text)
    _click(qtbot, dock.set_speed)
    assert not dock.set_speed.isChecked()
    assert window.last_message.startswith("Set Speed [m/s]:")
    assert window.bridge.latest["driver/status"].mode == "manual"


def test_from_table_and_start_follows_the_table_to_its_end(window, qtbot):
    pts = [(0.0, 0.0), (10.0, 0.0), (20.0, 1.0), (30.0, 4.0), (40.0, 9.0)]
    window.table.model.set_trajectory(Trajectory.from_points(pts))
    dock = window.auto_dock
    dock.from_table.setChecked(True)
    _type(qtbot, dock.path_speed, "5")
    window.show_plots()
    _click(qtbot, dock.wheel_direction)
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].mode == "follow", timeout=WAIT_MS)
    rows_seen = set()

    def arrived() -> bool:
        rows_seen.add(window.table.model.active_row)
        st = window.bridge.latest["driver/status"]
        return st.arrived and speed_of(window) < 0.05
    qtbot.waitUntil(arrived, timeout=WAIT_MS)
    pose = window.bridge.latest["pose"]
    end = pts[-1]
    path = Trajectory.from_points(pts)
    # it stopped on the last point: within the driver's final-approach reach of it, on the path
    assert math.hypot(pose.x - end[0], pose.y - end[1]) < 1.0
    assert abs(path.project(pose.x, pose.y).cross_track) < 0.5
    assert {1, 2, 3, 4} <= rows_seen  # the active waypoint moved down the table
    assert window.table.model.active_row == len(pts) - 1


def test_set_wheel_direction_drives_to_a_point(window, qtbot):
    dock = window.auto_dock
    dock.from_table.setChecked(False)
    _type(qtbot, dock.x_edit, "15")
    _type(qtbot, dock.y_edit, "0")
    _type(qtbot, dock.path_speed, "4")
    _click(qtbot, dock.wheel_direction)
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].arrived and speed_of(window) < 0.05,
                    timeout=WAIT_MS)
    pose = window.bridge.latest["pose"]
    assert math.hypot(pose.x - 15.0, pose.y) < 1.0
    _click(qtbot, dock.wheel_direction)
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].mode == "manual", timeout=WAIT_MS)


def test_bad_path_fields_are_refused(window, qtbot):
    dock = window.auto_dock
    dock.from_table.setChecked(False)
    _type(qtbot, dock.x_edit, "twelve")
    _click(qtbot, dock.wheel_direction)
    assert not dock.wheel_direction.isChecked() and "X [m]" in window.last_message
    dock.from_table.setChecked(True)
    window.table.model.set_trajectory(Trajectory.from_points([(0, 0), (5, 0)]))
    _type(qtbot, dock.path_speed, "")
    _click(qtbot, dock.wheel_direction)
    assert not dock.wheel_direction.isChecked() and "speed in every row" in window.last_message


def test_controllers_and_gains_change_live_and_bad_gains_are_refused(window, qtbot, embedded):
    dock = window.auto_dock
    dock.path_ctrl.setCurrentText("pure_pursuit")
    dock.path_gains.editors["lookahead_min"].setText("4")
    _click(qtbot, dock.apply_button)
    qtbot.waitUntil(lambda: embedded.driver_node.driver.params.path_controller == "pure_pursuit", timeout=WAIT_MS)
    assert embedded.driver_node.driver.params.gains_of("pure_pursuit").lookahead_min == 4.0
    dock.speed_gains.editors["kp"].setText("strong")
    _click(qtbot, dock.apply_button)
    assert "kp" in window.last_message and "not a number" in window.last_message
    dock.speed_gains.editors["kp"].setText("1.2")
    dock.speed_gains.editors["period"].setText("0.013")  # not a whole number of 10 ms physics steps
    _click(qtbot, dock.apply_button)
    qtbot.waitUntil(lambda: "refused" in window.last_message, timeout=WAIT_MS)
    # the running driver is kept
    assert embedded.driver_node.driver.params.gains_of("pure_pursuit").lookahead_min == 4.0


# -- Plan: the scenario's plan task --------------------------------------------------------------------------------

PLAN_MODES = ("velocity", "follow", "stop", "fallback")
"""A plan's modes (:class:`vilma.planning.planner.Plan`)."""


def _planned_window(qtbot, tmp_path, start: bool = True):
    """The main window on ``planned_parked_car`` embedded (started and heard from, if ``start``), and its backend."""
    from tests.gui.conftest import SPEED, shown_window
    from vilma.gui.backend import Embedded
    from vilma.gui.main_window import MainWindow

    backend = Embedded(load_scenario(find_scenario("planned_parked_car")), speed=SPEED)
    if start:
        return shown_window(qtbot, backend, tmp_path), backend
    w = MainWindow(backend, refresh_ms=100, record_dir=tmp_path)
    qtbot.addWidget(w)
    return w, backend


def test_plan_is_disabled_without_a_plan_task(window, qtbot):
    plan = window.auto_dock.plan_button
    assert window.backend.scenario.task.kind != "plan" and not plan.isEnabled()
    _click(qtbot, plan)
    assert not plan.isChecked() and window.bridge.latest["driver/status"].mode == "manual"


def test_a_refused_plan_order_shows_its_one_line_error_in_the_status_bar(qtbot, tmp_path):
    w, backend = _planned_window(qtbot, tmp_path, start=False)  # no simulator running: no pose of the car yet
    try:
        assert w.auto_dock.plan_button.isEnabled()
        _click(qtbot, w.auto_dock.plan_button)
        qtbot.waitUntil(lambda: "refused" in w.last_message, timeout=WAIT_MS)
        assert w.last_message.startswith("Plan: refused: plan: no pose of the car yet") and "\n" not in w.last_message
        assert w.statusBar().currentMessage() == w.last_message
        assert not w.auto_dock.plan_button.isChecked()  # shown off again, as other refused orders
        w.close()
    finally:
        backend.close()


@pytest.mark.slow
def test_plan_drives_the_parked_car_scenario_past_the_parked_car_on_the_map(qtbot, tmp_path, screenshots):
    """Plan starts the scenario's task with its planner (its lane and the next, 3.5 m to the left) and truth
    perception; beside the parked car the map shows its track's box and the chosen trajectory (the README's
    screenshot of an overtake)."""
    w, backend = _planned_window(qtbot, tmp_path)
    try:
        sc = backend.scenario
        setup = backend.driver_node.planning
        assert (setup.params, setup.perception, setup.laser) == (sc.planner, sc.perception, sc.sim.laser)
        (parked,) = sc.sim.traffic.at(0.0)[0]  # x, y [m], yaw [rad], speed [m/s], as the scenario's file has it
        length = np.ptp(sc.sim.traffic.outline[0, :, 0])
        w.show_plots()
        _click(qtbot, w.auto_dock.plan_button)

        def beside() -> bool:  # the car in the left lane, within the parked car's length of it
            p = w.bridge.latest["pose"]
            return abs(p.x - parked[0]) <= length and p.y > 2.0
        qtbot.waitUntil(beside, timeout=WAIT_MS)
        backend.stop()  # the picture of that moment
        w.plots.pause_button.click()
        w.plots.refresh(force=True)
        (box,) = w.plots.plan.tracks.objects
        assert math.hypot(box.x - parked[0], box.y - parked[1]) < 0.5
        assert (box.length, box.width) == pytest.approx((length, np.ptp(sc.sim.traffic.outline[0, :, 1])), abs=0.1)
        assert w.plots.plan.labels[0].isVisible() and w.plots.plan.labels[0].toPlainText() == str(box.id)
        assert len(w.plots.plan.chosen.xData) > 1 and w.bridge.latest["driver/status"].mode == "plan"
        w.status_dock.refresh()
        assert w.status_dock.value("plan.mode").split(":")[0] in PLAN_MODES
        w.plots.resize(2400, 360)  # a wide map, as the overtake is: 80 m by 18 m
        w.plots.path_plot.setRange(xRange=(40, 120), yRange=(-6, 12), padding=0)
        exporter = ImageExporter(w.plots.path_plot)  # the plot's own Export... (its context menu)
        exporter.parameters()["width"] = 1600  # sharper than the screen's pixels
        exporter.export(str(screenshots / "gui-overtake.png"))
        assert (screenshots / "gui-overtake.png").stat().st_size > 20_000
        w.close()
    finally:
        backend.close()
