"""The road on the map: the lanelets of the CommonRoad file, the traffic where the simulator has it at the sim time
(the file's recording, or where reactive traffic drove)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from PySide6.QtCore import Qt

from tests.gui.conftest import WAIT_MS, shown_window
from tests.world.test_commonroad import TUTORIAL, _lanelets
from tests.world.test_road_view import _obstacle
from vilma.app.batch import find_scenario
from vilma.bus.local import LocalBus
from vilma.gui.bridge import BusBridge
from vilma.gui.plots import PlotWindow
from vilma.scenario.spec import load_scenario
from vilma.world.road_view import road_view


def _xy(item) -> np.ndarray:
    return np.array([(p.x(), p.y()) for p in item.polygon()])


@pytest.fixture
def road_plots(qtbot):
    """A plot window on an empty bus with the tutorial's road; its task."""
    task = load_scenario(find_scenario("commonroad_tutorial")).road
    bridge = BusBridge(LocalBus())
    w = PlotWindow(bridge, road=road_view(task))
    qtbot.addWidget(w)
    yield w, task
    bridge.close()


def test_the_map_draws_the_files_lanelets_beneath_the_car(road_plots):
    plots, _ = road_plots
    lanes = _lanelets(TUTORIAL)
    drawn = [np.column_stack(c.getData()) for c in plots.road.boundaries]
    assert len(drawn) == 2 * len(lanes)
    for left, right in lanes.values():
        assert any(np.array_equal(d, left) for d in drawn) and any(np.array_equal(d, right) for d in drawn)
    surfaces = [_xy(s) for s in plots.road.surfaces]
    for left, right in lanes.values():
        assert any(np.allclose(s, np.vstack([left, right[::-1]])) for s in surfaces)
    for item in (*plots.road.surfaces, *plots.road.boundaries, *plots.road.traffic.values()):
        assert item.zValue() < plots.trajectory_curve.zValue() < plots.car_curve.zValue()
        assert item.scene() is plots.path_plot.scene()


def test_the_traffic_moves_to_where_the_file_has_it(road_plots):
    plots, task = road_plots
    length, width, states = _obstacle(TUTORIAL, "dynamicObstacle")
    (car,) = plots.road.traffic.values()
    for k, x, y, yaw in (states[0], states[10]):
        plots.road.show_at((k - task.time_step) * task.dt)
        assert car.isVisible()
        np.testing.assert_allclose(_xy(car).mean(axis=0), (x, y), atol=1e-9)
        # a box turned by yaw spans L |cos| + W |sin| along x
        assert np.ptp(_xy(car)[:, 0]) == pytest.approx(length * abs(np.cos(yaw)) + width * abs(np.sin(yaw)))
    plots.road.show_at((states[-1][0] - task.time_step + 1) * task.dt)
    assert not car.isVisible()  # its recording ended: it left the scene


@pytest.mark.slow
def test_screenshot_of_the_map_on_a_real_road(qtbot, tmp_path, screenshots):
    from vilma.gui.backend import Embedded

    backend = Embedded(load_scenario(find_scenario("commonroad_overtaking")), speed=4.0)
    try:
        w = shown_window(qtbot, backend, tmp_path)
        w.auto_dock.path_speed.setText("20")
        w.show_plots()
        qtbot.mouseClick(w.auto_dock.wheel_direction, Qt.MouseButton.LeftButton)
        h = w.bridge.history["path"]
        qtbot.waitUntil(lambda: len(h) and h.view()[-1, 0] > 0.8, timeout=WAIT_MS)
        w.plots.pause_button.click()  # the map holds still for the picture
        w.plots.refresh(force=True)
        (box,) = w.plots.road.traffic.values()  # the file's static obstacle, on the car's lane ahead
        np.testing.assert_allclose(_xy(box).mean(axis=0), w.plots.road.view.at(0.0)[0].pose[:2], atol=1e-9)
        w.plots.path_plot.setRange(xRange=(20, 110), yRange=(-6, 14), padding=0)
        assert w.plots.export_png(screenshots / "gui-road.png")
        assert (screenshots / "gui-road.png").stat().st_size > 20_000
        w.close()
    finally:
        backend.close()


def test_the_map_draws_the_traffic_where_the_simulator_has_it(qtbot, tmp_path):
    """The traffic the simulator's sensors read (here 5 m north of the file's, as a reactive run's would stray
    from it), not the file's recording."""
    from vilma.gui.backend import Embedded
    from vilma.gui.main_window import MainWindow

    sc = load_scenario(find_scenario("commonroad_tutorial"))
    tr = sc.sim.traffic
    moved = dataclasses.replace(tr, states=tr.states + np.array([0.0, 5.0, 0.0, 0.0]))
    backend = Embedded(dataclasses.replace(sc, sim=dataclasses.replace(sc.sim, traffic=moved)))
    try:
        w = MainWindow(backend, record_dir=tmp_path)
        qtbot.addWidget(w)
        (file_car,) = road_view(sc.road).at(0.0)
        ((car_id, box),) = [(i, b) for i, b in w.plots.road.traffic.items() if b.isVisible()]
        assert car_id == file_car.id
        np.testing.assert_allclose(_xy(box), file_car.footprint + np.array([0.0, 5.0]), atol=1e-9)
        w.close()
    finally:
        backend.close()
