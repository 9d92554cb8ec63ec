"""The road of a CommonRoad scenario on the map (the plot window's path plot, pannable and zoomable): the lanelets'
surface and boundaries (dashed where the file marks them), the goal region, and the traffic at the sim time
shown, moving as the run goes."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtGui import QBrush, QColor, QPen, QPolygonF
from PySide6.QtWidgets import QGraphicsPolygonItem

if TYPE_CHECKING:  # the roads extra, which only a road scenario needs
    from vilma.world.road_view import RoadView

SURFACE, BOUNDARY, GOAL = (225, 225, 225), (110, 110, 110), (40, 170, 60)
TRAFFIC, STATIC = (240, 140, 20), (130, 130, 130)


def _polygon(xy: np.ndarray, fill, edge, z: float) -> QGraphicsPolygonItem:
    """A closed polygon item through the points ``xy`` (n, 2) [m] (a cosmetic edge: one pixel at any zoom)."""
    item = QGraphicsPolygonItem(QPolygonF([pg.QtCore.QPointF(x, y) for x, y in xy]))
    item.setBrush(QBrush(QColor(*fill)))
    pen = QPen(QColor(*edge)) if edge is not None else QPen(Qt.PenStyle.NoPen)
    pen.setCosmetic(True)
    item.setPen(pen)
    item.setZValue(z)
    return item


class RoadLayer:
    """``view`` drawn on ``plot`` beneath its curves (z < 0); :meth:`show_at` moves the traffic."""

    def __init__(self, plot: pg.PlotItem, view: RoadView) -> None:
        self.plot, self.view = plot, view
        self.surfaces = [_polygon(la.surface, SURFACE, None, -30) for la in view.lanelets]
        self.boundaries: list[pg.PlotDataItem] = []
        for la in view.lanelets:
            for line, dashed in ((la.left, la.left_dashed), (la.right, la.right_dashed)):
                style = Qt.PenStyle.DashLine if dashed else Qt.PenStyle.SolidLine
                curve = pg.PlotDataItem(line[:, 0], line[:, 1], pen=pg.mkPen(BOUNDARY, width=1, style=style))
                curve.setZValue(-20)
                self.boundaries.append(curve)
        self.goal = [_polygon(g, (*GOAL, 60), GOAL, -15) for g in view.goal]
        self.traffic: dict[int, QGraphicsPolygonItem] = {}
        for item in (*self.surfaces, *self.boundaries, *self.goal):
            plot.addItem(item, ignoreBounds=isinstance(item, QGraphicsPolygonItem))
        self.show_at(0.0)

    def show_at(self, t: float) -> None:
        """Place the traffic where it is at sim time ``t`` [s] (hidden when out of the scene then)."""
        seen = set()
        for body in self.view.at(t):
            outline = body.footprint
            item = self.traffic.get(body.id)
            if item is None:
                item = self.traffic[body.id] = _polygon(outline, STATIC if body.static else TRAFFIC, (0, 0, 0), -10)
                self.plot.addItem(item, ignoreBounds=True)
            else:
                item.setPolygon(QPolygonF([pg.QtCore.QPointF(x, y) for x, y in outline]))
            item.setVisible(True)
            seen.add(body.id)
        for i, item in self.traffic.items():
            if i not in seen:
                item.setVisible(False)
