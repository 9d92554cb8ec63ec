"""The plot window (the paper's Figures 11 and 12, live): path, speed and target, steering, drive and brake
force, cross-track error.

The data stay in the bridge's ring buffers (an hour or more at the sensors'
rates, never thinned). Each refresh hands pyqtgraph only what can be seen:
for time plots the samples in the visible time span (a binary search on the
time column), reduced to the minimum and maximum of each pixel column
(:func:`peak_decimate`, so spikes stay visible); for the path the points in
the visible rectangle, strided down to :data:`PATH_POINTS` and drawn
connected only between consecutive samples. Zooming or panning redraws at
once from the full history.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import QFileDialog, QHBoxLayout, QLabel, QPushButton, QVBoxLayout, QWidget

from vilma.gui.bridge import HISTORY_COLUMNS, BusBridge
from vilma.gui.plan_layer import PlanLayer
from vilma.gui.road_layer import RoadLayer
from vilma.gui.waypoints import WaypointModel

if TYPE_CHECKING:
    from vilma.world.road_view import RoadView

PATH_POINTS = 6_000
"""Most points of the car's path drawn at once (a stride above that)."""
PLAN_TOPICS = ("perception/objects", "planning/plan")
"""Topics drawn on the map as they come (their latest message)."""


def peak_decimate(t: np.ndarray, y: np.ndarray, t0: float, t1: float, buckets: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples of ``(t, y)`` (``t`` increasing) in ``[t0, t1]`` with one neighbour each side, reduced to
    the minimum and maximum of each of ``buckets`` equal runs when there are more than ``2 buckets``.

    Returns times and values, shapes (m,), m <= 2 buckets + the remainder of a run.
    """
    i0 = max(int(np.searchsorted(t, t0, "left")) - 1, 0)
    i1 = min(int(np.searchsorted(t, t1, "right")) + 1, len(t))
    t, y = t[i0:i1], y[i0:i1]
    n = len(t)
    if n <= 2 * buckets:
        return t, y
    k = n // buckets
    m = k * buckets
    runs = y[:m].reshape(buckets, k)
    lo, hi = runs.min(axis=1), runs.max(axis=1)
    tt = np.repeat(t[:m:k], 2)
    tt[1::2] = t[k - 1:m:k]
    yy = np.column_stack([lo, hi]).ravel()
    return np.concatenate([tt, t[m:]]), np.concatenate([yy, y[m:]])


def _time_curve(plot: pg.PlotItem, color, name: str, style=None, finite: bool = False) -> pg.PlotDataItem:
    pen = pg.mkPen(color, width=1, style=style) if style is not None else pg.mkPen(color, width=1)
    return plot.plot(pen=pen, name=name, connect="finite" if finite else "all", skipFiniteCheck=not finite)


def legend_title(title: str, *entries: tuple[tuple[int, int, int], str, str]) -> str:
    """``title`` followed by each ``(colour, line, name)`` in its colour: the legend in the title bar, where it
    covers no curve (``line``: a short stroke drawn with text, such as "━" or "╌")."""
    keys = "".join(f'&nbsp;&nbsp;<span style="color:#{r:02x}{g:02x}{b:02x}">{line}&nbsp;{name}</span>'
                   for (r, g, b), line, name in entries)
    return f"{title}{keys}"


class PlotWindow(QWidget):
    """Several live plots at once, with pause, clear, zoom (mouse, Auto range), PNG and CSV export.

    Args:
        bridge: the history to draw.
        waypoints: the table whose points are the trajectory (red).
        interval_ms: refresh period while shown and not paused [ms].
        road: a CommonRoad scenario's road, goal and traffic, drawn beneath the path (the traffic moving with
            the car's sim time).
    """

    message = Signal(str)

    def __init__(self, bridge: BusBridge, waypoints: WaypointModel | None = None, interval_ms: int = 200,
                 parent=None, road: RoadView | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Vilma Plots")
        self.bridge, self.waypoints = bridge, waypoints
        pg.setConfigOptions(antialias=False)
        self.paused = False
        self.refreshes = 0
        bar = QHBoxLayout()
        self.pause_button = QPushButton("Pause", self)
        self.pause_button.setCheckable(True)
        self.pause_button.toggled.connect(self.set_paused)
        bar.addWidget(self.pause_button)
        for text, slot in (("Clear", self.clear), ("Auto range", self.auto_range), ("Export PNG", self._ask_png),
                           ("Export CSV", self._ask_csv)):
            b = QPushButton(text, self)
            b.clicked.connect(lambda _=False, s=slot: s())
            bar.addWidget(b)
        self.info = QLabel(self)
        bar.addWidget(self.info, 1)
        self.glw = pg.GraphicsLayoutWidget(self)
        self.glw.setBackground("w")
        lay = QVBoxLayout(self)
        lay.addLayout(bar)
        lay.addWidget(self.glw)

        g = self.glw
        self.path_plot = g.addPlot(row=0, col=0, rowspan=4, title=legend_title(
            "Path", ((240, 150, 150), "━", "trajectory"), ((0, 0, 230), "─", "car")))
        self.path_plot.setLabel("bottom", "x", units="m")
        self.path_plot.setLabel("left", "y", units="m")
        self.path_plot.setAspectLocked(True)
        # wide and pale beneath the car's line, so that both show where the car runs on it
        self.trajectory_curve = self.path_plot.plot(pen=pg.mkPen((240, 150, 150), width=5), symbol="o", symbolSize=3,
                                                    symbolPen=None, symbolBrush=(220, 110, 110), name="trajectory")
        self.car_curve = self.path_plot.plot(pen=pg.mkPen((0, 0, 230), width=1.5), name="car",
                                             skipFiniteCheck=True)
        self.car_curve.setZValue(self.trajectory_curve.zValue() + 1)
        self.car_marker = self.path_plot.plot(pen=None, symbol="o", symbolSize=10, symbolBrush=(0, 0, 230),
                                              symbolPen="w")
        """Where the car is: its latest pose."""
        self.car_marker.setZValue(self.car_curve.zValue() + 1)
        self.road = RoadLayer(self.path_plot, road) if road is not None else None
        self.plan = PlanLayer(self.path_plot)
        self.speed_plot = g.addPlot(row=0, col=1, title=legend_title(
            "Speed", ((0, 0, 230), "─", "speed"), ((220, 0, 0), "╌", "target")))
        self.speed_plot.setLabel("left", "speed", units="m/s")
        self.speed_curve = _time_curve(self.speed_plot, (0, 0, 230), "speed")
        self.target_curve = _time_curve(self.speed_plot, (220, 0, 0), "target", style=pg.QtCore.Qt.PenStyle.DashLine,
                                        finite=True)
        self.steer_plot = g.addPlot(row=1, col=1, title="Steering")
        self.steer_plot.setLabel("left", "angle", units="rad")
        self.steer_curve = _time_curve(self.steer_plot, (0, 130, 0), "steer")
        self.force_plot = g.addPlot(row=2, col=1, title=legend_title(
            "Drive and brake force", ((200, 100, 0), "─", "drive"), ((120, 0, 160), "─", "brake")))
        self.force_plot.setLabel("left", "force", units="N")
        self.drive_curve = _time_curve(self.force_plot, (200, 100, 0), "drive")
        self.brake_curve = _time_curve(self.force_plot, (120, 0, 160), "brake")
        self.cross_plot = g.addPlot(row=3, col=1, title="Cross-track error")
        self.cross_plot.setLabel("left", "error", units="m")
        self.cross_plot.setLabel("bottom", "sim time", units="s")
        self.cross_curve = _time_curve(self.cross_plot, (0, 0, 0), "cross-track", finite=True)
        for p in (self.steer_plot, self.force_plot, self.cross_plot):
            p.setXLink(self.speed_plot)
        self._drawing = False
        for p in (self.path_plot, self.speed_plot):
            p.vb.sigRangeChangedManually.connect(self._zoomed)
        g.ci.layout.setColumnStretchFactor(0, 3)
        g.ci.layout.setColumnStretchFactor(1, 4)
        self.resize(1100, 700)
        if waypoints is not None:
            waypoints.changed.connect(self.show_trajectory)
            self.show_trajectory()
        bridge.updated.connect(self._on_update)
        self.timer = QTimer(self)
        self.timer.timeout.connect(self.refresh)
        self.interval_ms = interval_ms

    # -- drawing --------------------------------------------------------------------------------------------

    def showEvent(self, event) -> None:  # noqa: N802 (Qt override)
        self.timer.start(self.interval_ms)
        self.refresh()
        super().showEvent(event)

    def hideEvent(self, event) -> None:  # noqa: N802 (Qt override)
        self.timer.stop()
        super().hideEvent(event)

    def set_paused(self, on: bool) -> None:
        """Freeze the display (the history keeps growing)."""
        self.paused = on
        self.pause_button.setText("Resume" if on else "Pause")
        if not on:
            self.refresh()

    def show_trajectory(self) -> None:
        """Draw the table's points as the trajectory."""
        try:
            xy = self.waypoints.trajectory().xy
        except ValueError:
            xy = np.empty((0, 2))
        self.trajectory_curve.setData(xy[:, 0], xy[:, 1])

    def _on_update(self, name: str) -> None:
        if name == "reset":
            self.bridge.taken(name)
            self.refresh(force=True)
        elif name in PLAN_TOPICS:
            self.bridge.taken(name)
            if not self.paused and self.isVisible():
                self._show_plan()

    def _show_plan(self) -> None:
        """The latest tracks and plan on the map, if recent in the sim time of the latest pose."""
        get = self.bridge.latest.get
        pose = get("pose")
        self.plan.show(get("perception/objects"), get("planning/plan"), pose.stamp_ns if pose is not None else None)

    def _zoomed(self, *_) -> None:
        if not self._drawing:
            self.refresh(force=True)

    def _time_span(self) -> tuple[float, float, int]:
        vb = self.speed_plot.vb
        buckets = max(int(vb.width()), 100)
        if vb.state["autoRange"][0]:
            return -math.inf, math.inf, buckets
        t0, t1 = vb.viewRange()[0]
        return t0, t1, buckets

    def _path_points(self, path: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """x, y and the connect flags of the car's path points to draw."""
        vb = self.path_plot.vb
        idx = np.arange(len(path))
        if not any(vb.state["autoRange"]) and len(path):
            (x0, x1), (y0, y1) = vb.viewRange()
            mx, my = 0.1 * (x1 - x0), 0.1 * (y1 - y0)
            x, y = path[:, 1], path[:, 2]
            idx = np.flatnonzero((x >= x0 - mx) & (x <= x1 + mx) & (y >= y0 - my) & (y <= y1 + my))
        stride = max(1, math.ceil(len(idx) / PATH_POINTS))
        idx = idx[::stride]
        connect = np.ones(len(idx), dtype=bool)
        connect[:-1] = np.diff(idx) <= stride  # no chord across a stretch outside the view
        return path[idx, 1], path[idx, 2], connect

    def refresh(self, force: bool = False) -> None:
        """Hand the plots what is visible of the history (skipped while paused or hidden unless ``force``)."""
        if not force and (self.paused or not self.isVisible()):
            return
        self._drawing = True
        try:
            self._draw()
        finally:
            self._drawing = False

    def _draw(self) -> None:
        h = self.bridge.history
        path = h["path"].view()
        x, y, connect = self._path_points(path)
        self.car_curve.setData(x, y, connect=connect)
        self.car_marker.setData(path[-1:, 1], path[-1:, 2])
        self._show_plan()
        if self.road is not None and len(path):
            self.road.show_at(float(path[-1, 0]))
        t0, t1, buckets = self._time_span()
        sp, dr, ac = h["speed"].view(), h["driver"].view(), h["actuators"].view()
        for curve, data, col in ((self.speed_curve, sp, 1), (self.target_curve, dr, 1), (self.cross_curve, dr, 3),
                                 (self.steer_curve, ac, 1), (self.drive_curve, ac, 2), (self.brake_curve, ac, 3)):
            curve.setData(*peak_decimate(data[:, 0], data[:, col], t0, t1, buckets))
        span = (path[-1, 0] - path[0, 0]) if len(path) > 1 else 0.0
        self.info.setText(f"{len(path)} poses over {span:.1f} s of sim time" + ("  (paused)" if self.paused else ""))
        self.refreshes += 1

    def clear(self) -> None:
        """Forget the history and empty the plots."""
        self.bridge.clear_history()
        self.refresh(force=True)

    def auto_range(self) -> None:
        """Zoom every plot to its data."""
        for p in (self.path_plot, self.speed_plot, self.steer_plot, self.force_plot, self.cross_plot):
            p.enableAutoRange()

    # -- export ---------------------------------------------------------------------------------------------

    def _ask_png(self) -> None:
        name, _ = QFileDialog.getSaveFileName(self, "Export PNG", "vilma-plots.png", "PNG (*.png)")
        if name:
            self.export_png(name)

    def _ask_csv(self) -> None:
        name, _ = QFileDialog.getSaveFileName(self, "Export CSV", "vilma-plots.csv", "CSV (*.csv)")
        if name:
            self.export_csv(name)

    def export_png(self, name: str | Path) -> bool:
        """Save the window as a PNG image."""
        self.refresh(force=True)
        ok = self.grab().save(str(name), "PNG")
        self.message.emit(f"plots saved to {name}" if ok else f"Export PNG: cannot write {name}; choose another "
                          "folder")
        return ok

    def export_csv(self, name: str | Path) -> list[Path]:
        """Write the history as CSV, one file per series: ``<name stem>-<series>.csv`` beside ``name``."""
        base = Path(name)
        out: list[Path] = []
        try:
            for series, cols in HISTORY_COLUMNS.items():
                file = base.with_name(f"{base.stem}-{series}.csv")
                data = self.bridge.history[series].view()
                with open(file, "w", newline="", encoding="utf-8") as f:
                    w = csv.writer(f)
                    w.writerow(cols)
                    w.writerows(np.round(data, 6).tolist())
                out.append(file)
        except OSError as e:
            self.message.emit(f"Export CSV: cannot write {e.filename} ({e.strerror}); choose another folder")
            return out
        self.message.emit(f"plot data saved to {', '.join(str(p) for p in out)}")
        return out
