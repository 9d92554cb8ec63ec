"""The keyboard mapping: the original's PowerTrain keys plus W/A/S/D (vilma-original.md section 7)."""

from __future__ import annotations

from PySide6.QtCore import Qt

from vilma.core.messages import Longitudinal
from vilma.gui import keyboard as kb


def test_keys_map_to_the_original_powertrain_and_release_returns_to_zero():
    k = kb.KeyboardDriver(velocity_limit=12.0)
    up = k.press(Qt.Key.Key_Up)
    assert (up.drive, up.steer, up.brake, up.longitudinal, up.velocity_limit) == (800.0, 0.0, 0.0,
                                                                                   Longitudinal.POWER, 12.0)
    left = k.press(Qt.Key.Key_A)
    assert left.steer == 0.3 and left.drive == 800.0
    assert k.press(Qt.Key.Key_A) is None  # already held
    both = k.press(Qt.Key.Key_Right)
    assert both.steer == 0.0  # left and right cancel
    assert k.release(Qt.Key.Key_A).steer == -0.3
    zero = k.release_all()
    assert (zero.drive, zero.steer, zero.brake) == (0.0, 0.0, 0.0)
    assert k.release(Qt.Key.Key_Up) is None


def test_brake_beats_gas_reverse_drives_back_and_the_hand_brake_spreads_100_over_four_wheels():
    k = kb.KeyboardDriver()
    k.press(Qt.Key.Key_W)
    braking = k.press(Qt.Key.Key_S)
    assert (braking.drive, braking.brake) == (0.0, 40.0)
    k.release_all()
    assert k.press(Qt.Key.Key_R).drive == -200.0
    assert k.press(Qt.Key.Key_H).brake == 100.0 * 2 / 4
    assert not k.handles(Qt.Key.Key_Q)
