"""The "Manual Controls" dock: hand wheel, power or acceleration, brake, recording, keyboard driving.

Any manual action first takes the car back from the self-driver (the
original's ``setManualControl``), then publishes an actuator command on the
bus. Power is in the original's units (``powerAmount``: 1000 takes the car
from 0 to 100 km/h in about 10.8 s) or, in acceleration mode, a share of the
car's largest acceleration [m/s²].
"""

from __future__ import annotations

import math
from pathlib import Path

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDockWidget,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)

from vilma.core.messages import ActuatorCommand, DriverOrder, Longitudinal
from vilma.gui.bridge import BusBridge
from vilma.gui.fields import FieldError, parse_number
from vilma.gui.keyboard import KeyboardDriver
from vilma.vehicle.params import VehicleParams

POSITION_LOG, SPEED_LOG = "PositionLog.txt", "SpeedLog.txt"
"""The original's file names (written in the recording folder)."""
POWER_FULL = 1000.0
"""Original power units at 100 % of the power slider."""


class ManualDock(QDockWidget):
    """Manual Controls (see the module docstring).

    Args:
        bridge: the bus side.
        vehicle: the car (steering limit, brake and acceleration ranges).
        record_dir: where Record Trajectory / Record Speed write ``PositionLog.txt`` / ``SpeedLog.txt``.
    """

    took_over = Signal()
    """Manual control was taken from the self-driver."""
    message = Signal(str)
    """Something to tell the user."""

    def __init__(self, bridge: BusBridge, vehicle: VehicleParams, record_dir: Path = Path(),
                 parent=None) -> None:
        super().__init__("Manual Controls", parent)
        self.setObjectName("manual_controls")
        self.bridge, self.vehicle, self.record_dir = bridge, vehicle, Path(record_dir)
        self.keyboard = KeyboardDriver()
        self.velocity_limit = self.keyboard.velocity_limit
        body = QWidget(self)
        lay = QVBoxLayout(body)
        self.power_label = QLabel("Current Power: -", body)
        self.max_speed_label = QLabel("Max Speed - m/s", body)
        lay.addWidget(self.power_label)
        lay.addWidget(self.max_speed_label)

        wheel = QGroupBox("Hand Wheel", body)
        wl = QVBoxLayout(wheel)
        top = round(vehicle.max_steer * 1000)
        self.wheel = QSlider(Qt.Orientation.Horizontal, wheel)
        self.wheel.setRange(-top, top)
        self.wheel.setToolTip(f"steering ±{vehicle.max_steer:g} rad; right of centre turns right")
        self.wheel.valueChanged.connect(self._wheel_moved)
        self.steer_label = QLabel("steering 0.000 rad", wheel)
        centre = QPushButton("Centre", wheel)
        centre.clicked.connect(lambda: self.wheel.setValue(0))
        row = QHBoxLayout()
        row.addWidget(self.steer_label)
        row.addWidget(centre)
        wl.addWidget(self.wheel)
        wl.addLayout(row)
        lay.addWidget(wheel)

        drive = QGroupBox("Power and brake", body)
        form = QFormLayout(drive)
        self.mode = QComboBox(drive)
        self.mode.addItem("power (original units)", Longitudinal.POWER)
        self.mode.addItem("acceleration [m/s²]", Longitudinal.ACCEL)
        self.mode.currentIndexChanged.connect(lambda _: self.send())
        form.addRow("mode", self.mode)
        self.power = self._slider(drive)
        self.brake = self._slider(drive)
        self.power_value = QLabel(drive)
        self.brake_value = QLabel(drive)
        form.addRow("power / accel [%]", self.power)
        form.addRow("", self.power_value)
        form.addRow("brake [%]", self.brake)
        form.addRow("", self.brake_value)
        self.max_speed = QLineEdit(f"{self.velocity_limit:g}", drive)
        self.max_speed.setToolTip("power mode: above this speed [m/s] the engine is cut (the original's "
                                  "velocityAmount)")
        self.max_speed.editingFinished.connect(self.apply_max_speed)
        form.addRow("max speed [m/s]", self.max_speed)
        lay.addWidget(drive)

        rec = QGroupBox("Recording", body)
        rl = QHBoxLayout(rec)
        self.record_trajectory = QPushButton("Record Trajectory", rec)
        self.record_speed = QPushButton("Record Speed", rec)
        for b, kind in ((self.record_trajectory, "trajectory"), (self.record_speed, "speed")):
            b.setCheckable(True)
            b.toggled.connect(lambda on, k=kind: self.set_recording(k, on))
            rl.addWidget(b)
        lay.addWidget(rec)

        self.keyboard_on = QCheckBox("Keyboard driving", body)
        self.keyboard_on.setChecked(True)
        self.keyboard_on.setToolTip("while the window has focus (not typing in a field): Up/W gas, Down/S brake, "
                                    "Left/A Right/D steer, R reverse, H hand brake; release: zero")
        lay.addWidget(self.keyboard_on)
        lay.addWidget(QLabel("keys: ↑/W gas  ↓/S brake  ←/A →/D steer  R reverse  H hand brake", body))
        lay.addStretch(1)
        self.setWidget(body)
        self._show_values()
        self.timer = QTimer(self)
        self.timer.timeout.connect(self.refresh)
        self.timer.start(250)

    def _slider(self, parent: QWidget) -> QSlider:
        s = QSlider(Qt.Orientation.Horizontal, parent)
        s.setRange(0, 100)
        s.valueChanged.connect(lambda _: self.send())
        return s

    # -- building commands ----------------------------------------------------------------------------------

    @property
    def steer(self) -> float:
        """The hand wheel's steering angle [rad], positive left."""
        return -self.wheel.value() / 1000.0

    def command(self) -> ActuatorCommand:
        """The command the controls hold now."""
        mode = self.mode.currentData()
        p = self.vehicle
        power, brake = self.power.value() / 100.0, self.brake.value() / 100.0
        if mode == Longitudinal.POWER:
            return ActuatorCommand(steer=self.steer, longitudinal=mode, drive=power * POWER_FULL,
                                   brake=brake * p.max_brake_force / (4.0 * p.brake_unit_force),
                                   velocity_limit=self.velocity_limit)
        return ActuatorCommand(steer=self.steer, longitudinal=mode, drive=power * p.actuators.max_accel,
                               brake=brake * p.max_brake_force)

    def _show_values(self) -> None:
        c = self.command()
        self.steer_label.setText(f"steering {c.steer:+.3f} rad")
        unit = "" if c.longitudinal == Longitudinal.POWER else " m/s²"
        self.power_value.setText(f"{c.drive:.3g}{unit}")
        self.brake_value.setText(f"{c.brake:.4g}{' N' if c.longitudinal == Longitudinal.ACCEL else ''}")

    def _wheel_moved(self, _value: int) -> None:
        self.send()

    def send(self, cmd: ActuatorCommand | None = None) -> None:
        """Take manual control and publish ``cmd`` (default: what the controls hold)."""
        self._show_values()
        self.take_over()
        self.bridge.command(cmd or self.command())

    def take_over(self) -> None:
        """Switch the self-driver to manual if it is driving."""
        status = self.bridge.latest.get("driver/status")
        if status is not None and status.mode != "manual":
            self.bridge.order(DriverOrder(action="manual"), "manual control")
            self.took_over.emit()

    def apply_max_speed(self) -> bool:
        """Read the max speed field; refused with a message when it is not a positive number."""
        try:
            v = parse_number(self.max_speed.text(), "Max speed [m/s]", 0.0, 200.0, low_open=True)
        except FieldError as e:
            self.message.emit(str(e))
            self.max_speed.setText(f"{self.velocity_limit:g}")
            return False
        if v != self.velocity_limit:
            self.velocity_limit = self.keyboard.velocity_limit = v
            if self.mode.currentData() == Longitudinal.POWER:
                self.send()
        return True

    # -- keyboard -------------------------------------------------------------------------------------------

    def key_press(self, key: int) -> bool:
        """A key went down; True if it is a driving key (then it was used)."""
        if not (self.keyboard_on.isChecked() and self.keyboard.handles(key)):
            return False
        cmd = self.keyboard.press(key)
        if cmd is not None:
            self._follow(cmd)
            self.send(cmd)
        return True

    def key_release(self, key: int) -> bool:
        """A key went up; True if it is a driving key."""
        if not self.keyboard.handles(key):
            return False
        cmd = self.keyboard.release(key)
        if cmd is not None:
            self._follow(cmd)
            self.send(cmd)
        return True

    def release_keys(self) -> None:
        """The window lost focus: release every held key."""
        cmd = self.keyboard.release_all()
        if cmd is not None:
            self._follow(cmd)
            self.send(cmd)

    def _follow(self, cmd: ActuatorCommand) -> None:
        """Move the controls to show a keyboard command without sending theirs."""
        p = self.vehicle
        for w, v in ((self.mode, 0), (self.wheel, round(-cmd.steer * 1000)),
                     (self.power, round(max(cmd.drive, 0.0) / POWER_FULL * 100)),
                     (self.brake, round(cmd.brake / (p.max_brake_force / (4.0 * p.brake_unit_force)) * 100))):
            w.blockSignals(True)
            w.setCurrentIndex(v) if isinstance(w, QComboBox) else w.setValue(v)
            w.blockSignals(False)

    # -- recording and display ------------------------------------------------------------------------------

    def set_recording(self, kind: str, on: bool) -> None:
        """Start or stop Record Trajectory (``trajectory``) or Record Speed (``speed``)."""
        button = self.record_trajectory if kind == "trajectory" else self.record_speed
        if on:
            path = self.record_dir / (POSITION_LOG if kind == "trajectory" else SPEED_LOG)
            try:
                self.bridge.start_recording(kind, path)
            except OSError as e:
                self.message.emit(f"Record {kind}: cannot write {path} ({e.strerror or e}); choose another folder")
                button.blockSignals(True)
                button.setChecked(False)
                button.blockSignals(False)
                return
            self.message.emit(f"recording {kind} to {path}")
        else:
            path = self.bridge.stop_recording(kind)
            if path is not None:
                self.message.emit(f"recorded {kind} in {path}")

    def refresh(self) -> None:
        """Show the power and speed limit of the last command on the bus."""
        cmd = self.bridge.latest.get("cmd")
        if cmd is None:
            return
        unit = {Longitudinal.POWER: "", Longitudinal.ACCEL: " m/s²", Longitudinal.FORCE: " N"}.get(cmd.longitudinal, "")
        self.power_label.setText(f"Current Power: {cmd.drive:.4g}{unit} ({cmd.longitudinal})")
        limit = cmd.velocity_limit
        self.max_speed_label.setText(f"Max Speed {limit:.3g} m/s" if math.isfinite(limit) else "Max Speed none")
