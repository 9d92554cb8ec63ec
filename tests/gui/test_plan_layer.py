"""The planned car on the map: its tracks' boxes, ids and velocity arrows, the predictions, the trajectory chosen and
the candidates, as the bus brings them, gone once stale; the plan's mode in Car Status."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pyqtgraph as pg
import pytest
from PySide6.QtCore import Qt

from tests.record.test_plan_scene import STAMP_NS, planned_cycle
from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core.messages import Pose
from vilma.gui.bridge import BusBridge
from vilma.gui.plan_layer import BARB, HEAD
from vilma.gui.plots import PlotWindow
from vilma.gui.status_dock import StatusDock
from vilma.record.plan_scene import ARROW_S


def _segments(curve) -> list[np.ndarray]:
    """The NaN-separated shapes handed to ``curve``, each (n, 2)."""
    xy = np.column_stack([curve.xData, curve.yData]) if curve.xData is not None else np.empty((0, 2))
    parts = (p[~np.isnan(p[:, 0])] for p in np.split(xy, np.flatnonzero(np.isnan(xy[:, 0]))))
    return [p for p in parts if len(p)]


def _paths(paths) -> list[np.ndarray]:
    return [np.column_stack([p.x, p.y]) for p in paths]


def _equal(drawn: list[np.ndarray], want: list[np.ndarray]) -> bool:
    return len(drawn) == len(want) and all(np.array_equal(d, w) for d, w in zip(drawn, want, strict=True))


@pytest.fixture
def planned(qtbot):
    """A shown plot window on a bus, a Car Status on the same bridge, and the bus."""
    bus = LocalBus()
    bridge = BusBridge(bus)
    plots = PlotWindow(bridge)
    status = StatusDock(bridge)
    qtbot.addWidget(plots)
    qtbot.addWidget(status)
    plots.show()
    yield plots, status, bus
    bridge.close()


def _publish_cycle(bus: LocalBus, qtbot, plots: PlotWindow):
    tracks, cycle = planned_cycle()
    bus.publish(topic("perception/objects"), tracks)
    bus.publish(topic("planning/plan"), cycle)
    qtbot.waitUntil(lambda: plots.plan.plan is cycle and plots.plan.tracks is tracks, timeout=10_000)
    return tracks, cycle


def _pose_at(bus: LocalBus, stamp_ns: int) -> None:
    bus.publish(topic("pose"), Pose(stamp_ns, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))


def test_the_map_draws_each_track_as_its_box_id_and_velocity_arrow(planned, qtbot):
    plots, _, bus = planned
    tracks, _ = _publish_cycle(bus, qtbot, plots)
    layer = plots.plan
    lead, crossing = tracks.objects  # 4.5 m x 1.8 m at (25, 0), yaw 0; 4 m x 2 m at (20, 6), yaw pi/2, 1 m/s north
    boxes = _segments(layer.boxes)
    assert len(boxes) == 2 and all(np.allclose(b[0], b[-1]) for b in boxes)  # closed outlines
    for box, o, (half_x, half_y) in ((boxes[0], lead, (2.25, 0.9)), (boxes[1], crossing, (1.0, 2.0))):
        np.testing.assert_allclose(box.min(axis=0), (o.x - half_x, o.y - half_y), atol=1e-12)
        np.testing.assert_allclose(box.max(axis=0), (o.x + half_x, o.y + half_y), atol=1e-12)
    shafts = _segments(layer.arrows)[::2]  # each arrow: its shaft, then its head's barbs
    np.testing.assert_allclose(shafts[1], [(20.0, 6.0), (20.0, 6.0 + 1.0 * ARROW_S)], atol=1e-12)
    np.testing.assert_allclose(shafts[0], [(25.0, 0.0), (25.0, 0.0)])  # standing: no length
    head = _segments(layer.arrows)[3]  # the crossing arrow's barbs through its tip, symmetric about the shaft
    reach, spread = HEAD * ARROW_S * math.cos(BARB), HEAD * ARROW_S * math.sin(BARB)
    np.testing.assert_allclose(head, [(20.0 + spread, 7.0 - reach), (20.0, 7.0), (20.0 - spread, 7.0 - reach)],
                               atol=1e-12)
    shown = [label for label in layer.labels if label.isVisible()]
    assert [label.textItem.toPlainText() for label in shown] == ["7", "9"]
    # centred above each box: the lead's half width, the crossing's half length (its yaw pi/2) over its centre
    np.testing.assert_allclose([(label.pos().x(), label.pos().y()) for label in shown], [(25.0, 0.9), (20.0, 8.0)])
    assert all(label.anchor == pg.Point(0.5, 1.0) for label in shown)  # the text's bottom centre there


def test_the_map_draws_the_trajectory_chosen_the_candidates_and_the_predictions(planned, qtbot):
    plots, _, bus = planned
    _, cycle = _publish_cycle(bus, qtbot, plots)
    layer = plots.plan
    assert _equal(_segments(layer.chosen), [np.column_stack([cycle.x, cycle.y])])
    free = [c for c in cycle.candidates if c.status == 0]
    rejected = [c for c in cycle.candidates if c.status != 0]
    assert free and {c.status for c in rejected} == {1, 2}
    assert _equal(_segments(layer.free), _paths(free)) and _equal(_segments(layer.rejected), _paths(rejected))
    assert _equal(_segments(layer.predictions), _paths(cycle.predictions))
    pen = {name: getattr(layer, name).opts["pen"] for name in ("chosen", "free", "rejected", "predictions")}
    assert pen["chosen"].widthF() > 2 * max(pen["free"].widthF(), pen["rejected"].widthF())
    assert pen["free"].color().alpha() < pen["rejected"].color().alpha() < 255  # free faint, both under the rest
    assert pen["free"].color().rgb() != pen["rejected"].color().rgb()
    assert pen["predictions"].style() == Qt.PenStyle.DashLine


def test_what_came_more_than_a_second_of_sim_time_ago_is_cleared_and_a_reset_clears_it(planned, qtbot):
    plots, _, bus = planned
    _, cycle = _publish_cycle(bus, qtbot, plots)
    layer = plots.plan
    _pose_at(bus, STAMP_NS + 900_000_000)
    plots.refresh()
    assert layer.plan is cycle and _segments(layer.chosen)
    _pose_at(bus, STAMP_NS + 1_100_000_000)
    plots.refresh()
    assert layer.plan is None and layer.tracks is None
    assert not any(_segments(c) for c in (layer.chosen, layer.free, layer.rejected, layer.predictions, layer.boxes))
    assert not any(label.isVisible() for label in layer.labels)
    bus.publish(topic("planning/plan"), msgspec.structs.replace(cycle, stamp_ns=STAMP_NS + 1_100_000_000))
    qtbot.waitUntil(lambda: layer.plan is not None, timeout=10_000)
    _pose_at(bus, 0)  # the simulation was reset: back to time 0
    qtbot.waitUntil(lambda: layer.plan is None, timeout=10_000)


def test_car_status_shows_the_plans_mode_and_a_fallbacks_reason(planned):
    _, status, bus = planned
    tracks, cycle = planned_cycle()
    status.refresh()
    assert status.value("plan.mode") == "-"
    bus.publish(topic("perception/objects"), tracks)
    bus.publish(topic("planning/plan"), msgspec.structs.replace(cycle, mode="follow", reason=""))
    status.refresh()
    assert status.value("plan.mode") == "follow"
    assert status.value("plan.tracks") == "2 (truth)"
    reason = "every candidate collides; comfortable stop at 3 m/s^2 within 37.5 m"
    bus.publish(topic("planning/plan"), msgspec.structs.replace(cycle, mode="fallback", reason=reason))
    status.refresh()
    assert status.value("plan.mode") == f"fallback: {reason}"
