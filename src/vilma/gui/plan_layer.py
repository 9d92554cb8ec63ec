"""A planned car's tracks and plan on the map (the plot window's path plot): each track's box with its id above it
and its velocity arrow, the objects' predicted futures (dashed), the trajectory chosen (thick), the candidates
evaluated (the free ones thin and faint, the rejected thin in orange). One curve a kind, its shapes separated by NaN
rows: a few curves however many tracks and paths."""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt

from vilma.core.messages import LocalPlan, Message, TrackedObject, TrackList
from vilma.record.plan_scene import ARROW_S, LIFETIME_S

TRACK, PREDICTED, CHOSEN = (30, 110, 255), (200, 40, 200), (20, 170, 40)
FREE, REJECTED = (120, 120, 120, 70), (240, 120, 20, 150)
BOX = np.array([(1, 1), (-1, 1), (-1, -1), (1, -1), (1, 1)]) / 2
"""A box's outline, closed, in lengths and widths from its centre."""
HEAD, BARB = 0.3, 0.4
"""An arrow's head: its barbs' length [share of the arrow] and angle to the shaft [rad]."""


def joined(lines: Iterable[np.ndarray]) -> np.ndarray:
    """The polylines ``lines`` (each (n, 2) [m]) as one (m, 2) array, a NaN row after each (none: (0, 2))."""
    gap = np.full((1, 2), np.nan)
    return np.vstack([part for line in lines for part in (line, gap)] or [np.empty((0, 2))])


def box_outline(o: TrackedObject) -> np.ndarray:
    """The closed outline (5, 2) [m] of ``o``'s box: its length along its yaw, its width across, about its centre."""
    c, s = math.cos(o.yaw), math.sin(o.yaw)
    return BOX * (o.length, o.width) @ np.array([[c, s], [-s, c]]) + (o.x, o.y)


def velocity_arrow(o: TrackedObject) -> np.ndarray:
    """``o``'s velocity arrow (7, 2) [m], NaN-separated: from its centre to where it is in :data:`ARROW_S`, then
    the two barbs of the head."""
    tail = np.array([o.x, o.y])
    travel = np.array([o.vx, o.vy]) * ARROW_S
    tip = tail + travel
    back = -HEAD * travel
    barbs = [tip + back @ np.array([[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]) for a in (BARB, -BARB)]
    return np.array([tail, tip, (np.nan, np.nan), barbs[0], tip, barbs[1], (np.nan, np.nan)])


def _paths(paths: Sequence) -> np.ndarray:
    return joined(np.column_stack([p.x, p.y]) for p in paths)


class PlanLayer:
    """Tracks and plans drawn on ``plot`` (above the road, beneath the car's path); :meth:`show` replaces them."""

    def __init__(self, plot: pg.PlotItem) -> None:
        self.plot = plot
        self.tracks: TrackList | None = None
        self.plan: LocalPlan | None = None
        """The messages drawn (None: nothing)."""
        self.free = self._curve(FREE, 1, 0.1)
        self.rejected = self._curve(REJECTED, 1, 0.2)
        self.predictions = self._curve(PREDICTED, 1.5, 0.3, Qt.PenStyle.DashLine)
        self.boxes = self._curve(TRACK, 2, 0.4)
        self.arrows = self._curve(TRACK, 1.5, 0.4)
        self.chosen = self._curve(CHOSEN, 4, 0.5)
        self.labels: list[pg.TextItem] = []
        """One a track drawn, with its id; the rest hidden, for the next tracks."""

    def _curve(self, color, width: float, z: float, style=Qt.PenStyle.SolidLine) -> pg.PlotDataItem:
        curve = pg.PlotDataItem(pen=pg.mkPen(color, width=width, style=style), connect="finite")
        curve.setZValue(z)
        self.plot.addItem(curve, ignoreBounds=True)  # the car, not the candidates ahead of it, sets the view
        return curve

    def show(self, tracks: TrackList | None, plan: LocalPlan | None, now_ns: int | None) -> None:
        """Draw ``tracks`` and ``plan``, each only if stamped within :data:`LIFETIME_S` of sim time ``now_ns`` [ns]
        (None: any time), else nothing of it; the messages drawn already are not drawn again."""
        tracks, plan = self._fresh(tracks, now_ns), self._fresh(plan, now_ns)
        if tracks is not self.tracks:
            self._draw_tracks(tracks)
        if plan is not self.plan:
            self._draw_plan(plan)

    @staticmethod
    def _fresh(msg: Message | None, now_ns: int | None) -> Message | None:
        # both ways: after a reset the sim time is back before the last messages of the previous run
        fresh = msg is not None and (now_ns is None or abs(now_ns - msg.stamp_ns) <= LIFETIME_S * 1e9)
        return msg if fresh else None

    def _draw_tracks(self, tracks: TrackList | None) -> None:
        self.tracks = tracks
        objects = tracks.objects if tracks is not None else []
        outlines = [box_outline(o) for o in objects]
        self.boxes.setData(*joined(outlines).T)
        self.arrows.setData(*joined(velocity_arrow(o) for o in objects).T)
        for i, (o, outline) in enumerate(zip(objects, outlines, strict=True)):
            if i == len(self.labels):
                self.labels.append(pg.TextItem(color=TRACK, anchor=(0.5, 1.0)))
                self.labels[i].setZValue(2)
                self.plot.addItem(self.labels[i], ignoreBounds=True)
            self.labels[i].setText(str(o.id))
            self.labels[i].setPos(o.x, outline[:, 1].max())  # above its box: readable over the road's obstacle
            self.labels[i].setVisible(True)
        for label in self.labels[len(objects):]:
            label.setVisible(False)

    def _draw_plan(self, plan: LocalPlan | None) -> None:
        self.plan = plan
        candidates = plan.candidates if plan is not None else []
        self.chosen.setData(*(np.array([plan.x, plan.y]) if plan is not None else np.empty((2, 0))))
        self.free.setData(*_paths([c for c in candidates if c.status == 0]).T)
        self.rejected.setData(*_paths([c for c in candidates if c.status != 0]).T)
        self.predictions.setData(*_paths(plan.predictions if plan is not None else []).T)
