"""The "Automatic Driving" dock: speed holding, driving to a point or along the table, the scenario's plan task,
trajectory tools, controllers and their gains.

Orders go to the self-driver on ``driver/cmd`` (:class:`~vilma.core.messages.DriverOrder`);
the trajectory tools are those of :mod:`vilma.trajectory` applied to the table.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDockWidget,
    QFileDialog,
    QFormLayout,
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QLineEdit,
    QPushButton,
    QScrollArea,
    QVBoxLayout,
    QWidget,
)

from vilma.control import registry
from vilma.core.messages import ActuatorCommand, DriverOrder, DriverStatus
from vilma.gui.bridge import BusBridge
from vilma.gui.fields import FieldError, parse_number
from vilma.gui.gains import ParamsEditor
from vilma.gui.waypoints import WaypointTable
from vilma.scenario.orders import task_order
from vilma.trajectory import (
    Trajectory,
    TrajectoryFileError,
    increase_point_count,
    load_trajectory,
    save_trajectory,
    smooth_iterative,
)
from vilma.trajectory.smooth import ALPHA, BETA, TOLERANCE

MAX_SPEED = 70.0
"""Largest speed accepted in a field [m/s] (252 km/h)."""
STOP_DECEL = 3.0
"""Braking of the Stop button [m/s²]."""
FILE_FILTER = "Trajectories (*.txt *.csv *.gpx);;All files (*)"


class AutoDock(QDockWidget):
    """Automatic Driving (see the module docstring).

    Args:
        bridge: the bus side.
        backend: :class:`~vilma.gui.backend.Embedded` or :class:`~vilma.gui.backend.Remote`.
        table: the waypoint table the tools work on.
    """

    message = Signal(str)
    """Something to tell the user."""
    plot_requested = Signal()
    """Plot Trajectory was clicked."""

    def __init__(self, bridge: BusBridge, backend, table: WaypointTable, parent=None) -> None:
        super().__init__("Automatic Driving", parent)
        self.setObjectName("automatic_driving")
        self.bridge, self.backend, self.table = bridge, backend, table
        body = QWidget(self)
        lay = QVBoxLayout(body)
        for group in (self._speed_group, self._path_group, self._tools_group, self._controllers_group):
            lay.addWidget(group(body))
        lay.addStretch(1)
        scroll = QScrollArea(self)
        scroll.setWidget(body)
        scroll.setWidgetResizable(True)
        self.setWidget(scroll)
        bridge.updated.connect(self._on_update)

    # -- the groups -------------------------------------------------------------------------------------------

    def _speed_group(self, body: QWidget) -> QGroupBox:
        """Current Speed, Set Speed and its field."""
        speed = QGroupBox("Speed", body)
        sl = QGridLayout(speed)
        self.current_speed = QPushButton("Current Speed", speed)
        self.current_speed.setToolTip("hold the speed measured now")
        self.set_speed = QPushButton("Set Speed", speed)
        self.speed_edit = QLineEdit("5", speed)
        self.speed_edit.setToolTip(f"target speed [m/s], 0..{MAX_SPEED:g}")
        for b in (self.current_speed, self.set_speed):
            b.setCheckable(True)
        self.current_speed.toggled.connect(self._current_speed_toggled)
        self.set_speed.toggled.connect(self._set_speed_toggled)
        sl.addWidget(self.current_speed, 0, 0, 1, 2)
        sl.addWidget(self.set_speed, 1, 0)
        sl.addWidget(self.speed_edit, 1, 1)
        return speed

    def _path_group(self, body: QWidget) -> QGroupBox:
        """Go to (X, Y) or along the table, at a speed; Plan; Stop."""
        path = QGroupBox("Path", body)
        pf = QFormLayout(path)
        self.x_edit, self.y_edit = QLineEdit("20", path), QLineEdit("0", path)
        xy = QHBoxLayout()
        xy.addWidget(self.x_edit)
        xy.addWidget(self.y_edit)
        pf.addRow("X, Y [m]", xy)
        self.from_table = QCheckBox("From Table", path)
        pf.addRow(self.from_table)
        self.path_speed = QLineEdit("5", path)
        self.path_speed.setToolTip("speed along the path [m/s]; empty: the table's speeds")
        pf.addRow("path speed [m/s]", self.path_speed)
        self.wheel_direction = QPushButton("Set Wheel Direction to (X, Y)", path)
        self.wheel_direction.setCheckable(True)
        self.wheel_direction.setToolTip("start (checked) or stop (unchecked) driving to the point or along the "
                                        "table")
        self.wheel_direction.toggled.connect(self._wheel_direction_toggled)
        pf.addRow(self.wheel_direction)
        self.plan_button = QPushButton("Plan", path)
        self.plan_button.setCheckable(True)
        sc = self.backend.scenario
        self.plan_button.setEnabled(sc is not None and sc.task.kind == "plan")
        self.plan_button.setToolTip(
            "start (checked) or stop (unchecked) the scenario's plan task: perceive, predict and plan along its "
            "route to its goal" if self.plan_button.isEnabled() else "the scenario has no plan task (task: {plan: "
            "true}); start the GUI with one to plan")
        self.plan_button.toggled.connect(self._plan_toggled)
        pf.addRow(self.plan_button)
        self.stop_button = QPushButton("Stop", path)
        self.stop_button.setToolTip("take the car from the driver and brake to a stop")
        self.stop_button.clicked.connect(self.stop_car)
        pf.addRow(self.stop_button)
        return path

    def _tools_group(self, body: QWidget) -> QGroupBox:
        """The trajectory tools: smoothing weights, Smooth, Generate Points, files, plot."""
        self.buttons: dict[str, QPushButton] = {}
        tools = QGroupBox("Trajectory", body)
        tf = QGridLayout(tools)
        self.alpha_edit, self.beta_edit = QLineEdit(f"{ALPHA:g}", tools), QLineEdit(f"{BETA:g}", tools)
        self.tolerance_edit = QLineEdit(f"{TOLERANCE:g}", tools)
        self.alpha_edit.setToolTip("weight_data (alpha) > 0")
        self.beta_edit.setToolTip("weight_smooth (beta) >= 0")
        self.tolerance_edit.setToolTip("stop when a sweep changes the points by less than this in total [m]")
        form = QFormLayout()
        form.addRow("alpha", self.alpha_edit)
        form.addRow("beta", self.beta_edit)
        form.addRow("tolerance [m]", self.tolerance_edit)
        tf.addLayout(form, 0, 0, 1, 2)
        for i, (text, slot) in enumerate((("Smooth Trajectory", self.smooth), ("Generate Points", self.generate_points),
                                          ("Input From File", self.open_file), ("Save To File", self.save_file),
                                          ("Plot Trajectory", self.plot_requested.emit))):
            b = QPushButton(text, tools)
            b.clicked.connect(lambda _=False, s=slot: s())
            tf.addWidget(b, 1 + i // 2, i % 2)
            self.buttons[text] = b
        return tools

    def _controllers_group(self, body: QWidget) -> QGroupBox:
        """The controllers (from the registry) and their gains."""
        ctrl = QGroupBox("Controllers", body)
        cl = QFormLayout(ctrl)
        self.speed_ctrl, self.path_ctrl = QComboBox(ctrl), QComboBox(ctrl)
        self.speed_ctrl.addItems(registry.names(registry.SPEED))
        self.path_ctrl.addItems(registry.names(registry.PATH))
        self.speed_gains, self.path_gains = ParamsEditor(ctrl), ParamsEditor(ctrl)
        cl.addRow("speed", self.speed_ctrl)
        cl.addRow(self.speed_gains)
        cl.addRow("path", self.path_ctrl)
        cl.addRow(self.path_gains)
        self.apply_button = QPushButton("Apply controllers", ctrl)
        self.apply_button.clicked.connect(self.apply_controllers)
        cl.addRow(self.apply_button)
        self.show_params(self.backend.driver_params)
        self.speed_ctrl.currentTextChanged.connect(
            lambda name: self.speed_gains.set_params(self.backend.driver_params.gains_of(name)))
        self.path_ctrl.currentTextChanged.connect(
            lambda name: self.path_gains.set_params(self.backend.driver_params.gains_of(name)))
        return ctrl

    # -- speed ----------------------------------------------------------------------------------------------

    def _quiet(self, button: QPushButton, on: bool) -> None:
        button.blockSignals(True)
        button.setChecked(on)
        button.blockSignals(False)

    def _toggles(self) -> tuple[QPushButton, ...]:
        """The automatic functions, at most one on."""
        return self.current_speed, self.set_speed, self.wheel_direction, self.plan_button

    def _only(self, button: QPushButton) -> None:
        """Show every automatic function but ``button`` off."""
        for b in self._toggles():
            if b is not button:
                self._quiet(b, False)

    def _current_speed_toggled(self, on: bool) -> None:
        if on:
            self._only(self.current_speed)
            self.speed_edit.setEnabled(True)
            self.bridge.order(DriverOrder(action="hold_speed"), "Current Speed")
        else:
            self._manual_if_idle()

    def _set_speed_toggled(self, on: bool) -> None:
        if on:
            try:
                v = parse_number(self.speed_edit.text(), "Set Speed [m/s]", 0.0, MAX_SPEED)
            except FieldError as e:
                self.message.emit(str(e))
                self._quiet(self.set_speed, False)
                return
            self._only(self.set_speed)
            self.speed_edit.setEnabled(False)
            self.bridge.order(DriverOrder(action="set_speed", speed=v), "Set Speed")
        else:
            self.speed_edit.setEnabled(True)
            self._manual_if_idle()

    def _manual_if_idle(self) -> None:
        if not any(b.isChecked() for b in self._toggles()):
            self.bridge.order(DriverOrder(action="manual"), "manual control")

    def release_toggles(self) -> None:
        """Show every automatic function off (manual control was taken)."""
        for b in self._toggles():
            self._quiet(b, False)
        self.speed_edit.setEnabled(True)
        self.table.highlight(-1)

    # -- path -----------------------------------------------------------------------------------------------

    def _wheel_direction_toggled(self, on: bool) -> None:
        if not on:
            self.table.highlight(-1)
            self._manual_if_idle()
            return
        try:
            order = self.path_order()
        except (FieldError, ValueError) as e:
            self.message.emit(str(e))
            self._quiet(self.wheel_direction, False)
            return
        self._only(self.wheel_direction)
        self.speed_edit.setEnabled(True)
        self.bridge.order(order, "From Table" if self.from_table.isChecked() else "Set Wheel Direction")

    def _plan_toggled(self, on: bool) -> None:
        if not on:
            self._manual_if_idle()
            return
        self._only(self.plan_button)
        self.speed_edit.setEnabled(True)
        self.table.highlight(-1)
        self.bridge.order(task_order(self.backend.scenario), "Plan")

    def path_order(self) -> DriverOrder:
        """The order for the path fields: go to (X, Y), or follow the table.

        Raises:
            FieldError: a bad number, or a table that cannot be driven (too few points, no speeds).
        """
        text = self.path_speed.text().strip()
        speed = math.nan if not text else parse_number(text, "path speed [m/s]", 0.0, MAX_SPEED, low_open=True)
        if not self.from_table.isChecked():
            x = parse_number(self.x_edit.text(), "X [m]")
            y = parse_number(self.y_edit.text(), "Y [m]")
            if math.isnan(speed):
                raise FieldError("path speed [m/s]: empty; type the speed to drive to (X, Y) at")
            return DriverOrder(action="go_to", x=x, y=y, speed=speed)
        try:
            path = self.table.model.trajectory()
        except ValueError as e:
            raise FieldError(f"From Table: {e}") from None
        if len(path) < 2:
            raise FieldError("From Table: the table needs at least 2 points")
        if not math.isnan(speed):
            return DriverOrder(action="follow", points=[tuple(p) for p in path.xy.tolist()], speed=speed)
        if path.speed is None:
            raise FieldError("From Table: give a path speed, or a speed in every row of the table")
        return DriverOrder(action="follow", points=[tuple(p) for p in path.xy.tolist()], speeds=path.speed.tolist())

    def stop_car(self) -> None:
        """Take the car from the driver and brake it to a stop (STOP_DECEL)."""
        self.release_toggles()
        self.bridge.order(DriverOrder(action="manual"), "Stop")
        self.bridge.command(ActuatorCommand(brake=self.backend.vehicle.mass * STOP_DECEL))

    def _on_update(self, name: str) -> None:
        if name != "driver/status":
            return
        st: DriverStatus | None = self.bridge.latest.get("driver/status")
        if st is None:
            return
        if st.mode == "follow" and self.from_table.isChecked() and self.wheel_direction.isChecked():
            self.table.highlight(min(st.index + 1, self.table.model.rowCount() - 1))
            if st.arrived:
                self.table.highlight(self.table.model.rowCount() - 1)

    # -- trajectory tools -----------------------------------------------------------------------------------

    def _table_path(self, need: int, what: str) -> Trajectory | None:
        try:
            path = self.table.model.trajectory()
        except ValueError as e:
            self.message.emit(f"{what}: {e}")
            return None
        if len(path) < need:
            self.message.emit(f"{what}: needs at least {need} points in the table, it has {len(path)}")
            return None
        return path

    def smooth(self) -> bool:
        """Smooth Trajectory: the paper's Algorithm 1 with the alpha, beta, tolerance fields, on the table."""
        try:
            alpha = parse_number(self.alpha_edit.text(), "alpha", 0.0, 1.0, low_open=True)
            beta = parse_number(self.beta_edit.text(), "beta", 0.0, 1.0)
            tol = parse_number(self.tolerance_edit.text(), "tolerance [m]", 0.0, low_open=True)
        except FieldError as e:
            self.message.emit(str(e))
            return False
        if alpha + 2 * beta >= 2:  # the sweeps are SOR with factor alpha + 2 beta: they converge below 2
            self.message.emit(f"Smooth: alpha + 2 beta = {alpha + 2 * beta:g} must stay below 2 or the sweeps "
                              "never settle; lower alpha or beta")
            return False
        path = self._table_path(3, "Smooth Trajectory")
        if path is None:
            return False
        xy = smooth_iterative(path.xy, alpha, beta, tol)
        self.table.model.set_trajectory(Trajectory(xy, path.speed))
        self.message.emit(f"smoothed {len(path)} points (alpha {alpha:g}, beta {beta:g}, tolerance {tol:g})")
        return True

    def generate_points(self) -> bool:
        """Generate Points: a midpoint between each pair of rows (n -> 2n - 1)."""
        path = self._table_path(2, "Generate Points")
        if path is None:
            return False
        self.table.model.set_trajectory(increase_point_count(path))
        self.message.emit(f"Generate Points: {len(path)} -> {2 * len(path) - 1} points")
        return True

    def open_file(self) -> None:
        """Input From File (asks for the file)."""
        name, _ = QFileDialog.getOpenFileName(self, "Input From File", "", FILE_FILTER)
        if name:
            self.load_file(name)

    def load_file(self, name: str | Path) -> bool:
        """Fill the table from a trajectory file (the original's x y pairs, CSV or GPX)."""
        try:
            path = load_trajectory(name)
        except TrajectoryFileError as e:
            self.message.emit(str(e))
            return False
        self.table.model.set_trajectory(path)
        self.from_table.setChecked(True)
        self.message.emit(f"loaded {len(path)} points from {name}")
        return True

    def save_file(self) -> None:
        """Save To File (asks for the file)."""
        name, _ = QFileDialog.getSaveFileName(self, "Save To File", "PositionLog.txt", FILE_FILTER)
        if name:
            self.write_file(name)

    def write_file(self, name: str | Path) -> bool:
        """Write the table to a trajectory file (.csv: CSV with speeds, else the original's x y lines)."""
        try:
            save_trajectory(name, self.table.model.trajectory())
        except ValueError as e:
            self.message.emit(f"Save To File: {e}")
            return False
        self.message.emit(f"saved {self.table.model.rowCount()} points to {name}")
        return True

    # -- controllers ----------------------------------------------------------------------------------------

    def show_params(self, params) -> None:
        """Show the driver's controllers and gains."""
        for combo, name in ((self.speed_ctrl, params.speed_controller), (self.path_ctrl, params.path_controller)):
            combo.blockSignals(True)
            combo.setCurrentText(name)
            combo.blockSignals(False)
        self.speed_gains.set_params(params.gains_of(params.speed_controller))
        self.path_gains.set_params(params.gains_of(params.path_controller))

    def controller_params(self):
        """The driver parameters the controller fields describe.

        Raises:
            FieldError: a gain that is not a number or that the controller refuses.
        """
        base = self.backend.driver_params
        s, p = self.speed_ctrl.currentText(), self.path_ctrl.currentText()
        try:
            return dataclasses.replace(base, speed_controller=s, path_controller=p).with_gains(
                {s: self.speed_gains.values(), p: self.path_gains.values()})
        except ValueError as e:
            raise FieldError(str(e)) from None

    def apply_controllers(self) -> bool:
        """Swap the driver's controllers and gains live (over the bus, a ``tune`` order)."""
        try:
            params = self.controller_params()
        except FieldError as e:
            self.message.emit(str(e))
            return False
        self.bridge.call(lambda: self.backend.set_driver_params(params),
                         f"controllers {params.speed_controller} + {params.path_controller}")
        return True

