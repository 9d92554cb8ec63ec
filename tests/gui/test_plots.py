"""The plot window: live curves from the history, pause, clear, PNG and CSV export."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from tests.gui.conftest import WAIT_MS
from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core.messages import Pose
from vilma.gui.bridge import HISTORY_COLUMNS, BusBridge
from vilma.gui.plots import PlotWindow


def _n(curve) -> int:
    """Points handed to a curve (before clipping and downsampling for display)."""
    return 0 if curve.xData is None else len(curve.xData)


def test_plots_follow_the_history_pause_clear_and_export(window, qtbot, tmp_path):
    plots = window.plots
    window.auto_dock.speed_edit.setText("3")
    window.auto_dock.set_speed.click()
    window.show_plots()
    qtbot.waitUntil(lambda: _n(plots.speed_curve) > 50, timeout=WAIT_MS)
    h = window.bridge.history
    t = plots.speed_curve.xData
    assert np.all(np.diff(t) > 0) and np.all(np.isin(t, h["speed"].view()[:, 0]))
    plots.pause_button.click()
    frozen = plots.refreshes
    n = len(h["path"])
    qtbot.waitUntil(lambda: len(h["path"]) > n + 20, timeout=WAIT_MS)
    assert plots.refreshes == frozen  # the display waits, the history grows
    plots.pause_button.click()
    assert plots.refreshes > frozen
    files = plots.export_csv(tmp_path / "run.csv")
    assert [f.name for f in files] == [f"run-{s}.csv" for s in HISTORY_COLUMNS]
    with open(files[1], newline="") as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == HISTORY_COLUMNS["speed"] and len(rows) > 50
    assert plots.export_png(tmp_path / "p.png") and (tmp_path / "p.png").stat().st_size > 5000
    assert not plots.export_png(tmp_path / "missing" / "p.png") and "cannot write" in window.last_message
    assert plots.export_csv(tmp_path / "missing" / "run.csv") == [] and "cannot write" in window.last_message
    plots.clear()
    assert _n(plots.car_curve) < 20  # only what arrived since
    xy = window.table.model
    xy.insert_rows(0, 2)
    assert _n(plots.trajectory_curve) == 2  # the table's points are the red trajectory


@pytest.fixture
def plots(qtbot):
    """A plot window on an empty bus."""
    bridge = BusBridge(LocalBus())
    w = PlotWindow(bridge)
    qtbot.addWidget(w)
    yield w
    bridge.close()


def test_the_legends_stand_in_the_titles_and_the_trajectory_shows_under_the_car(plots):
    for plot in (plots.path_plot, plots.speed_plot, plots.steer_plot, plots.force_plot, plots.cross_plot):
        assert plot.legend is None  # no legend box inside a plot, over its curves
    for plot, curves in ((plots.path_plot, (plots.trajectory_curve, plots.car_curve)),
                         (plots.speed_plot, (plots.speed_curve, plots.target_curve)),
                         (plots.force_plot, (plots.drive_curve, plots.brake_curve))):
        title = plot.titleLabel.text
        for curve in curves:
            assert curve.name() in title and curve.opts["pen"].color().name() in title
    trajectory, car = plots.trajectory_curve, plots.car_curve
    assert car.zValue() > trajectory.zValue() and trajectory.opts["pen"].widthF() > 2 * car.opts["pen"].widthF()


def test_a_dot_marks_where_the_car_is_on_the_map(plots):
    plots.refresh(force=True)
    assert _n(plots.car_marker) == 0  # no pose yet: no car
    for i in range(3):
        plots.bridge.bus.publish(topic("pose"), Pose(i * 10_000_000, float(i), 2.0 * i, 0.0, 0.0, 0.0, 0.0))
    plots.refresh(force=True)
    assert (list(plots.car_marker.xData), list(plots.car_marker.yData)) == ([2.0], [4.0])  # the latest pose
    assert plots.car_marker.zValue() > plots.car_curve.zValue()
