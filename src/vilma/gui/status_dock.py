"""The "Car Status" dock: every sensor's latest reading, refreshed by a timer (250 ms as the original)."""

from __future__ import annotations

import math

from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import QDockWidget, QFormLayout, QGroupBox, QLabel, QScrollArea, QVBoxLayout, QWidget

from vilma.core.geometry import yaw_from_quaternion
from vilma.gui.bridge import BusBridge

GROUPS: tuple[tuple[str, tuple[tuple[str, str], ...]], ...] = (
    ("Position (exact)", (("pose.x", "X [m]"), ("pose.y", "Y [m]"), ("pose.z", "Z [m]"))),
    ("Orientation (exact)", (("pose.qx", "qX"), ("pose.qy", "qY"), ("pose.qz", "qZ"), ("pose.qw", "qW"),
                             ("pose.yaw", "yaw [rad]"))),
    ("Linear velocity (world)", (("vel.x", "X [m/s]"), ("vel.y", "Y [m/s]"), ("vel.z", "Z [m/s]"),
                                 ("vel.speed", "speed [m/s]"))),
    ("Angular velocity (body)", (("vel.wx", "X [rad/s]"), ("vel.wy", "Y [rad/s]"), ("vel.wz", "Z [rad/s]"))),
    ("GPS", (("gps.lat", "latitude [deg]"), ("gps.lon", "longitude [deg]"), ("gps.alt", "altitude [m]"),
             ("gps.x", "local x [m]"), ("gps.y", "local y [m]"))),
    ("IMU orientation", (("imu.qx", "qX"), ("imu.qy", "qY"), ("imu.qz", "qZ"), ("imu.qw", "qW"),
                         ("imu.yaw", "yaw [rad]"))),
    ("IMU linear acceleration", (("imu.ax", "X [m/s²]"), ("imu.ay", "Y [m/s²]"), ("imu.az", "Z [m/s²]"))),
    ("IMU angular velocity", (("imu.wx", "X [rad/s]"), ("imu.wy", "Y [rad/s]"), ("imu.wz", "Z [rad/s]"))),
    ("Wheel speeds", (("wheel.fl", "FL [rad/s]"), ("wheel.fr", "FR [rad/s]"), ("wheel.rl", "RL [rad/s]"),
                      ("wheel.rr", "RR [rad/s]"))),
    ("Simulation", (("sim.link", "link"), ("sim.time", "sim time [s]"), ("sim.rtf", "real-time factor"),
                    ("sim.watchdog", "watchdog"), ("sim.autonomous", "commands from"),
                    ("driver.mode", "driver mode"))),
    ("Planning", (("plan.mode", "plan mode"), ("plan.tracks", "tracked objects"))),
)
"""Group title -> (key, label) of each value shown."""


def _f(v: float, digits: int = 3) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


class StatusDock(QDockWidget):
    """Car Status: position, orientation, velocities, GPS, IMU, wheel speeds, simulation and link state.

    Args:
        bridge: where the latest messages are.
        interval_ms: refresh period [ms] (the original's 250).
    """

    def __init__(self, bridge: BusBridge, interval_ms: int = 250, parent=None) -> None:
        super().__init__("Car Status", parent)
        self.setObjectName("car_status")
        self.bridge = bridge
        self.labels: dict[str, QLabel] = {}
        body = QWidget()
        lay = QVBoxLayout(body)
        for title, rows in GROUPS:
            box = QGroupBox(title, body)
            form = QFormLayout(box)
            form.setContentsMargins(6, 2, 6, 2)
            for key, text in rows:
                lab = QLabel("-", box)
                lab.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
                lab.setAlignment(Qt.AlignmentFlag.AlignRight)
                form.addRow(text, lab)
                self.labels[key] = lab
            lay.addWidget(box)
        lay.addStretch(1)
        scroll = QScrollArea(self)
        scroll.setWidget(body)
        scroll.setWidgetResizable(True)
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        body.setMinimumWidth(body.sizeHint().width() + 60)  # room for the values
        scroll.setMinimumWidth(body.minimumWidth() + 20)
        self.labels["plan.mode"].setWordWrap(True)  # a fallback's reason is a sentence
        self.setWidget(scroll)
        self.timer = QTimer(self)
        self.timer.timeout.connect(self.refresh)
        self.set_interval(interval_ms)

    def set_interval(self, ms: int) -> None:
        """Refresh every ``ms`` milliseconds (>= 10)."""
        if not 10 <= ms <= 60_000:
            raise ValueError(f"status refresh must be 10..60000 ms, got {ms}")
        self.timer.start(ms)

    def value(self, key: str) -> str:
        """The text shown for ``key`` (e.g. ``pose.x``)."""
        return self.labels[key].text()

    def _set(self, key: str, text: str) -> None:
        self.labels[key].setText(text)

    def refresh(self) -> None:
        """Show the latest readings."""
        get = self.bridge.latest.get
        if (p := get("pose")) is not None:
            qx, qy, qz, qw = p.quaternion
            for k, v in (("x", p.x), ("y", p.y), ("z", p.z), ("qx", qx), ("qy", qy), ("qz", qz), ("qw", qw),
                         ("yaw", p.yaw)):
                self._set(f"pose.{k}", _f(v))
        if (v := get("velocity")) is not None:
            for k, x in (("x", v.vx_world), ("y", v.vy_world), ("z", v.vz_world), ("speed", v.speed),
                         ("wx", v.wx), ("wy", v.wy), ("wz", v.wz)):
                self._set(f"vel.{k}", _f(x))
        if (g := get("gps")) is not None:
            for k, x, d in (("lat", g.latitude, 9), ("lon", g.longitude, 9), ("alt", g.altitude, 3), ("x", g.x, 3),
                            ("y", g.y, 3)):
                self._set(f"gps.{k}", _f(x, d))
        if (m := get("imu")) is not None:
            for k, x in (("qx", m.qx), ("qy", m.qy), ("qz", m.qz), ("qw", m.qw),
                         ("yaw", yaw_from_quaternion(m.qx, m.qy, m.qz, m.qw)), ("ax", m.ax), ("ay", m.ay),
                         ("az", m.az), ("wx", m.wx), ("wy", m.wy), ("wz", m.wz)):
                self._set(f"imu.{k}", _f(x))
        if (w := get("wheel_speed")) is not None:
            for k in ("fl", "fr", "rl", "rr"):
                self._set(f"wheel.{k}", _f(getattr(w, k)))
        self._set("sim.link", "connected" if self.bridge.connected else "DISCONNECTED")
        if (s := get("sim/status")) is not None:
            self._set("sim.time", _f(s.stamp_ns * 1e-9, 2))
            self._set("sim.rtf", _f(s.real_time_factor, 2))
            self._set("sim.watchdog", "TRIPPED: car stopped" if s.watchdog_tripped else "ok")
            self._set("sim.autonomous", "driver" if s.autonomous else "manual")
        if (d := get("driver/status")) is not None:
            self._set("driver.mode", d.mode + (" (arrived)" if d.arrived else "") + (f": {d.error}" if d.error else ""))
        if (p := get("planning/plan")) is not None:
            self._set("plan.mode", p.mode + (f": {p.reason}" if p.reason else ""))
        if (t := get("perception/objects")) is not None:
            self._set("plan.tracks", f"{len(t.objects)} ({t.source})")
