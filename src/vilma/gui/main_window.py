"""The main window ("Vilma Driver"): waypoint table in the centre, Car Status, Manual Controls, Automatic
Driving and Camera docks, menus, the link state in the status bar, keyboard driving."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from PySide6.QtCore import QEvent, QObject, Qt
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import (
    QAbstractSpinBox,
    QApplication,
    QFileDialog,
    QLabel,
    QLineEdit,
    QMainWindow,
    QMessageBox,
    QPlainTextEdit,
    QTextEdit,
)

from vilma import __version__
from vilma.core.files import write_atomic
from vilma.core.messages import DriverOrder
from vilma.gui.auto_dock import AutoDock
from vilma.gui.backend import default_scenario
from vilma.gui.bridge import BusBridge
from vilma.gui.camera_dock import CameraDock
from vilma.gui.manual_dock import ManualDock
from vilma.gui.plots import PlotWindow
from vilma.gui.status_dock import StatusDock
from vilma.gui.waypoints import WaypointTable
from vilma.record.road_scene import scenario_road
from vilma.scenario.fields import SpecError
from vilma.scenario.spec import Scenario, TaskSpec, load_scenario, to_yaml

TEXT_INPUTS = (QLineEdit, QAbstractSpinBox, QTextEdit, QPlainTextEdit)
"""Widgets that keep the keys typed into them (no keyboard driving there)."""


class MainWindow(QMainWindow):
    """The control and monitoring window.

    Args:
        backend: :class:`~vilma.gui.backend.Embedded` or :class:`~vilma.gui.backend.Remote`.
        refresh_ms: Car Status refresh period [ms] (the original's 250).
        plot_ms: plot refresh period [ms].
        record_dir: where the recordings go.
        history_seconds: plot history kept [s].
    """

    def __init__(self, backend, refresh_ms: int = 250, plot_ms: int = 200, record_dir: Path = Path(),
                 history_seconds: float = 3600.0) -> None:
        super().__init__()
        self.backend = backend
        self.setWindowTitle(f"Vilma Driver: {backend.describe()}")
        world = backend.world_topics
        self.bridge = BusBridge(backend.bus, backend.car, history_seconds=history_seconds, world_topics=world,
                                parent=self)
        self.table = WaypointTable(parent=self)
        self.setCentralWidget(self.table)
        self.status_dock = StatusDock(self.bridge, refresh_ms, self)
        self.manual_dock = ManualDock(self.bridge, backend.vehicle, record_dir, self)
        self.auto_dock = AutoDock(self.bridge, backend, self.table, self)
        self.addDockWidget(Qt.DockWidgetArea.LeftDockWidgetArea, self.status_dock)
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.manual_dock)
        self.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, self.auto_dock)
        self.camera_dock = CameraDock(self.bridge, world, parent=self)
        self.addDockWidget(Qt.DockWidgetArea.BottomDockWidgetArea, self.camera_dock)
        self.camera_dock.setVisible(bool(self.camera_dock.topics))
        self.plots = PlotWindow(self.bridge, self.table.model, plot_ms, road=scenario_road(
            backend.scenario, backend.sim.config if backend.embedded else None))
        self.last_message = ""
        self.link = QLabel(self)
        self.statusBar().addPermanentWidget(self.link)
        self._show_link(False)
        for source in (self.table.message, self.manual_dock.message, self.auto_dock.message, self.plots.message):
            source.connect(self.notify)
        self.manual_dock.took_over.connect(self.auto_dock.release_toggles)
        self.auto_dock.plot_requested.connect(self.show_plots)
        self.bridge.replied.connect(self._replied)
        self.bridge.connection_changed.connect(self._show_link)
        self.bridge.updated.connect(self._updated)
        self._menus()
        self.resize(1400, 900)
        QApplication.instance().installEventFilter(self)
        if backend.scenario is not None and backend.scenario.reference_path() is not None:
            self._arm_task(backend.scenario)

    # -- menus ----------------------------------------------------------------------------------------------

    def _menus(self) -> None:
        def action(menu, text, slot, shortcut=None) -> QAction:
            a = QAction(text, self)
            a.triggered.connect(lambda _=False: slot())
            if shortcut is not None:
                a.setShortcut(shortcut)
            menu.addAction(a)
            return a

        f = self.menuBar().addMenu("&File")
        action(f, "Open trajectory...", self.auto_dock.open_file, QKeySequence.StandardKey.Open)
        action(f, "Save trajectory...", self.auto_dock.save_file, QKeySequence.StandardKey.Save)
        f.addSeparator()
        action(f, "Open scenario...", self._ask_open_scenario)
        action(f, "Save scenario...", self._ask_save_scenario)
        f.addSeparator()
        action(f, "Quit", self.close, QKeySequence.StandardKey.Quit)
        s = self.menuBar().addMenu("&Simulation")
        action(s, "Reset", self.reset_simulation)
        action(s, "Stop the car", self.auto_dock.stop_car)
        v = self.menuBar().addMenu("&View")
        action(v, "Plots", self.show_plots)
        for dock in (self.status_dock, self.manual_dock, self.auto_dock, self.camera_dock):
            v.addAction(dock.toggleViewAction())
        h = self.menuBar().addMenu("&Help")
        action(h, "About", self.about)

    def about(self) -> None:
        """The About box."""
        QMessageBox.about(self, "About vilma", self.about_text())

    def about_text(self) -> str:
        """What the About box says."""
        return (f"vilma {__version__}: simulate, drive and monitor an autonomous car.\n"
                "A Python rebuild of the VILMA MORSE + ROS + Qt workbench (UNICAMP, 2015).\n"
                f"Now: {self.backend.describe()}.")

    # -- messages and state ---------------------------------------------------------------------------------

    def notify(self, text: str) -> None:
        """Show a message in the status bar (and keep it as :attr:`last_message`)."""
        self.last_message = text
        self.statusBar().showMessage(text, 15_000)

    def _replied(self, what: str, reply) -> None:
        if not reply.ok:
            self.notify(f"{what}: refused: {reply.error}")
            if what in ("Set Speed", "Current Speed", "Set Wheel Direction", "From Table", "Plan"):
                self.auto_dock.release_toggles()
        elif what.startswith("controllers"):
            self.notify(f"{what}: applied")

    def _show_link(self, connected: bool) -> None:
        if connected:
            self.link.setText("connected")
            self.link.setStyleSheet("QLabel { color: white; background: #2a2; padding: 2px 6px; }")
        else:
            self.link.setText("DISCONNECTED: no simulator heard; retrying")
            self.link.setStyleSheet("QLabel { color: white; background: #c22; padding: 2px 6px; }")

    def _updated(self, name: str) -> None:
        self.bridge.taken(name)

    def show_plots(self) -> None:
        """Open (or raise) the plot window."""
        self.plots.show()
        self.plots.raise_()

    def reset_simulation(self) -> None:
        """Back to the start pose at time 0 (the driver goes manual)."""
        self.auto_dock.release_toggles()
        self.bridge.order(DriverOrder(action="manual"), "manual control")
        self.bridge.sim_control("reset")
        self.notify("simulation reset")

    # -- scenarios ------------------------------------------------------------------------------------------

    def _ask_open_scenario(self) -> None:
        name, _ = QFileDialog.getOpenFileName(self, "Open scenario", "", "Scenarios (*.yaml *.yml);;All files (*)")
        if name:
            self.open_scenario(name)

    def open_scenario(self, name: str | Path) -> bool:
        """Load a scenario's path into the table and its controllers into Automatic Driving."""
        try:
            sc = load_scenario(name)
            path = sc.reference_path()
        except (SpecError, ValueError, OSError) as e:
            self.notify(f"Open scenario: {e}")
            return False
        self._arm_task(sc)
        self.auto_dock.show_params(sc.driver)
        self.notify(f"scenario {sc.name}: {len(path) if path is not None else 0} points in the table; its "
                    "controllers are shown (Apply to use them)")
        return True

    def _arm_task(self, sc: Scenario) -> None:
        """Put ``sc``'s path in the table (driven From Table) and its task's speed in the path speed."""
        path = sc.reference_path()
        if path is not None:
            self.table.model.set_trajectory(path)
            self.auto_dock.from_table.setChecked(True)
        if sc.task.speed is not None:
            self.auto_dock.path_speed.setText(f"{sc.task.speed:g}")

    def _ask_save_scenario(self) -> None:
        name, _ = QFileDialog.getSaveFileName(self, "Save scenario", "scenario.yaml", "Scenarios (*.yaml)")
        if name:
            self.save_scenario(name)

    def scenario(self) -> Scenario:
        """The scenario the window describes: the car and sensors run now, the controllers shown, the table as
        the course and the path speed as the task.

        Raises:
            ValueError: the table or a field cannot make a scenario.
        """
        base = self.backend.scenario or default_scenario()
        path = self.table.model.trajectory()
        speed = float(self.auto_dock.path_speed.text() or "nan")
        if not speed > 0:
            raise ValueError("give a path speed > 0 m/s to save the table as the scenario's task")
        task = TaskSpec(course=tuple(tuple(p) for p in path.xy.tolist()), speed=speed)
        return dataclasses.replace(base, task=task, driver=self.auto_dock.controller_params(), file=None,
                                   initial=dataclasses.replace(base.initial, x=None, y=None, yaw=None))

    def save_scenario(self, name: str | Path) -> bool:
        """Write :meth:`scenario` as YAML (atomically)."""
        try:
            write_atomic(Path(name), to_yaml(self.scenario()))
        except (ValueError, OSError) as e:
            self.notify(f"Save scenario: {e}")
            return False
        self.notify(f"scenario saved to {name}")
        return True

    # -- keyboard -------------------------------------------------------------------------------------------

    def eventFilter(self, obj: QObject, event: QEvent) -> bool:  # noqa: N802 (Qt override)
        t = event.type()
        if t in (QEvent.Type.KeyPress, QEvent.Type.KeyRelease) \
                and not isinstance(QApplication.focusWidget(), TEXT_INPUTS) and not event.isAutoRepeat():
            if obj is not self.windowHandle() and obj is not self and not self._mine(obj):
                return False
            handled = (self.manual_dock.key_press(event.key()) if t == QEvent.Type.KeyPress
                       else self.manual_dock.key_release(event.key()))
            if handled:
                return True
        elif t == QEvent.Type.WindowDeactivate and obj is self:
            self.manual_dock.release_keys()
        return False

    def _mine(self, obj: QObject) -> bool:
        while obj is not None:
            if obj is self:
                return True
            obj = obj.parent()
        return False

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        QApplication.instance().removeEventFilter(self)
        self.plots.close()
        self.bridge.close(wait=False)
        self.auto_dock.close()
        super().closeEvent(event)

