"""Manual Controls against the embedded simulator: keys, hand wheel, power, recording."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt

from tests.gui.conftest import WAIT_MS, speed_of
from vilma.core.messages import Longitudinal
from vilma.gui import keyboard as kb
from vilma.sensors.velocity import VelocityParams
from vilma.trajectory import load_speed_log, load_trajectory


def _next(commands, predicate):
    msg = commands.wait(predicate, timeout=WAIT_MS / 1000)
    assert msg is not None, "no such command was published"
    return msg


def test_a_key_press_publishes_its_command_and_the_release_zeroes_it(window, qtbot, commands):
    target = window.table.view  # keys go to the window's focus widget, not a text field
    for key, field, value in ((Qt.Key.Key_Up, "drive", kb.GAS_POWER), (Qt.Key.Key_W, "drive", kb.GAS_POWER),
                              (Qt.Key.Key_R, "drive", kb.REVERSE_POWER), (Qt.Key.Key_Left, "steer", kb.STEER),
                              (Qt.Key.Key_D, "steer", -kb.STEER), (Qt.Key.Key_Down, "brake", kb.BRAKE),
                              (Qt.Key.Key_H, "brake", kb.HAND_BRAKE)):
        qtbot.keyPress(target, key)
        cmd = _next(commands, lambda m, f=field, v=value: getattr(m, f) == v)
        assert cmd.longitudinal == Longitudinal.POWER and not cmd.autonomous
        qtbot.keyRelease(target, key)
        zero = _next(commands, lambda m: True)
        assert (zero.drive, zero.steer, zero.brake) == (0.0, 0.0, 0.0)


def test_holding_gas_moves_the_car_and_typing_in_a_field_does_not_drive(window, qtbot, commands):
    qtbot.keyPress(window.table.view, Qt.Key.Key_Up)
    qtbot.waitUntil(lambda: speed_of(window) > 1.0, timeout=WAIT_MS)
    assert window.manual_dock.power.value() == round(kb.GAS_POWER / 10)  # the slider shows the key's power
    qtbot.keyRelease(window.table.view, Qt.Key.Key_Up)
    _next(commands, lambda m: m.drive == 0.0)
    commands.drain()
    edit = window.auto_dock.speed_edit
    edit.setFocus()
    edit.clear()
    qtbot.keyClicks(edit, "sw")
    assert edit.text() == "sw" and all(m.drive == 0.0 for m in commands.drain())


def test_hand_wheel_and_power_sliders_publish_commands(window, qtbot, commands):
    dock = window.manual_dock
    dock.wheel.setValue(300)  # right of centre: turn right
    cmd = _next(commands, lambda m: m.steer != 0.0)
    assert cmd.steer == -0.3
    dock.power.setValue(50)
    cmd = _next(commands, lambda m: m.drive != 0.0)
    assert cmd.longitudinal == Longitudinal.POWER and cmd.drive == 500.0 and cmd.velocity_limit == 20.0
    dock.mode.setCurrentIndex(1)
    cmd = _next(commands, lambda m: m.longitudinal == Longitudinal.ACCEL)
    assert cmd.drive == 0.5 * window.backend.vehicle.actuators.max_accel
    dock.max_speed.setText("-3")
    assert not dock.apply_max_speed() and "Max speed" in window.last_message and dock.max_speed.text() == "20"


def test_manual_control_takes_the_car_from_the_driver(window, qtbot):
    dock = window.auto_dock
    dock.speed_edit.setText("3")
    dock.set_speed.click()
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].mode == "set_speed", timeout=WAIT_MS)
    qtbot.keyPress(window.table.view, Qt.Key.Key_Down)
    qtbot.waitUntil(lambda: window.bridge.latest["driver/status"].mode == "manual", timeout=WAIT_MS)
    assert not dock.set_speed.isChecked()
    qtbot.keyRelease(window.table.view, Qt.Key.Key_Down)


def test_recording_writes_files_the_loaders_read_back(window, qtbot, tmp_path):
    dock = window.manual_dock
    window.auto_dock.speed_edit.setText("3")
    window.auto_dock.set_speed.click()
    qtbot.waitUntil(lambda: speed_of(window) > 1.0, timeout=WAIT_MS)
    dock.record_trajectory.click()
    dock.record_speed.click()
    t0 = window.bridge.latest["pose"].stamp_ns
    qtbot.waitUntil(lambda: window.bridge.latest["pose"].stamp_ns - t0 > 3e9, timeout=WAIT_MS)
    dock.record_trajectory.click()
    dock.record_speed.click()
    assert not window.bridge.recording("trajectory") and "recorded speed" in window.last_message
    path = load_trajectory(tmp_path / "PositionLog.txt")
    assert len(path) >= 3 / 0.25  # a line every 250 ms of sim time
    assert np.all(np.diff(path.xy[:, 0]) > 0)  # the car drives along +x (yaw 0)
    t, v = load_speed_log(tmp_path / "SpeedLog.txt")
    sample = 1.0 / VelocityParams().rate_hz  # the recorder writes the first reading at or after each 250 ms
    assert np.all(np.abs(np.diff(t) - 0.25) <= sample + 1e-9)
    assert abs((t[-1] - t[0]) / (len(t) - 1) - 0.25) <= sample / (len(t) - 1) + 1e-9
    assert np.all((v > 0.5) & (v < 3.5))
    assert (tmp_path / "SpeedLog.txt").read_text(encoding="utf-8").startswith("Tempo desde")


def test_recording_into_a_missing_folder_is_refused(window, tmp_path):
    dock = window.manual_dock
    dock.record_dir = tmp_path / "missing"
    dock.record_trajectory.click()
    assert not dock.record_trajectory.isChecked() and "cannot write" in window.last_message
