"""The Camera dock: the chosen camera's latest image where it is, depth as grey, bad images dropped, no cameras."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from PySide6.QtGui import QColor

from tests.record.world_messages import GREY, SQUARE, depth_image, depth_ramp, red_square
from vilma.bus.local import LocalBus
from vilma.bus.topics import topic
from vilma.core.messages import Image
from vilma.gui.bridge import BusBridge
from vilma.gui.camera_dock import DEPTH_RANGE, CameraDock, depth_levels

CAMERAS = ("camera/front_left", "camera/front_left/depth")


@pytest.fixture
def dock(qtbot):
    bus = LocalBus()
    bridge = BusBridge(bus, world_topics=(*CAMERAS, "laser"))
    d = CameraDock(bridge, (*CAMERAS, "laser"), interval_ms=50)
    qtbot.addWidget(d)
    d.resize(640, 520)
    d.show()
    yield bus, d
    bridge.close()


def _rgb(image, x: int, y: int) -> tuple[int, int, int]:
    c = QColor(image.pixel(x, y))
    return c.red(), c.green(), c.blue()


def test_the_red_square_is_shown_where_it_is(dock, qtbot):
    bus, d = dock
    assert [d.combo.itemText(i) for i in range(d.combo.count())] == list(CAMERAS)  # cameras only
    bus.publish(topic("camera/front_left"), red_square(stamp_ns=1_250_000_000, pad=6))
    qtbot.waitUntil(lambda: d.view.image is not None, timeout=5000)  # on the dock's own timer
    img = d.view.image
    x, y, w, h = SQUARE
    assert (img.width(), img.height()) == (160, 120)
    assert _rgb(img, x + w // 2, y + h // 2) == (255, 0, 0) and _rgb(img, x, y) == (255, 0, 0)
    assert _rgb(img, x - 1, y) == (GREY,) * 3 and _rgb(img, x + w, y + h) == (GREY,) * 3
    assert d.info.text() == "160x120 rgb8 (colour), t 1.25 s"

    shot = d.view.grab().toImage()  # what is on the screen: scaled to fit, centred
    scale = min(shot.width() / 160, shot.height() / 120)
    left, top = (shot.width() - 160 * scale) / 2, (shot.height() - 120 * scale) / 2

    def on_screen(px: float, py: float) -> tuple[int, int, int]:
        return _rgb(shot, round(left + px * scale), round(top + py * scale))

    assert scale > 2
    assert on_screen(x + w / 2, y + h / 2) == (255, 0, 0)
    assert on_screen(x + 2, y + h - 2) == (255, 0, 0)
    assert on_screen(x - 3, y + h / 2) == (GREY,) * 3 and on_screen(x + w / 2, y + h + 3) == (GREY,) * 3
    assert on_screen(10, 10) == (GREY,) * 3


def test_depth_is_grey_over_a_fixed_range(dock, qtbot):
    bus, d = dock
    bus.publish(topic("camera/front_left/depth"), depth_image())
    d.combo.setCurrentText("camera/front_left/depth")
    img = d.view.image
    assert img is not None and (img.width(), img.height()) == (64, 48)
    levels = depth_levels(depth_ramp(), *DEPTH_RANGE)
    got = np.array([[QColor(img.pixel(i, j)).red() for i in range(0, 64, 9)] for j in range(48)])
    assert np.array_equal(got, levels[:, ::9])
    assert levels[0, 0] == 0 and levels[-1, 0] == round(255 * 48 / 50)  # sky (inf) black; 2 m near white
    assert "32FC1" in d.info.text()


def test_depth_levels_are_fixed_whatever_the_image():
    d = np.array([0.0, 25.0, 50.0, 80.0, np.inf, np.nan], np.float32)
    assert depth_levels(d, 0.0, 50.0).tolist() == [255, 128, 0, 0, 0, 0]
    assert depth_levels(d, 10.0, 20.0).tolist() == [255, 0, 0, 0, 0, 0]


def test_a_malformed_image_is_dropped_with_a_warning_and_the_last_good_one_stays(dock, caplog):
    bus, d = dock
    good = red_square()
    bus.publish(topic("camera/front_left"), good)
    d.refresh()
    shown = d.view.image
    with caplog.at_level(logging.WARNING, logger="vilma.gui"):
        for _ in range(3):
            bus.publish(topic("camera/front_left"), Image(2, "f", 160, 120, "rgb8", 480, good.data[:-480]))
            d.refresh()
    assert d.view.image is shown
    assert d.info.text() == "bad image dropped: 57120 bytes of data, not height 120 x step 480 = 57600"
    assert [r.getMessage() for r in caplog.records] == [
        "camera camera/front_left: 57120 bytes of data, not height 120 x step 480 = 57600; image dropped"]


def test_without_cameras_the_dock_says_so(qtbot):
    bridge = BusBridge(LocalBus(), world_topics=("laser",))
    d = CameraDock(bridge, ("laser",))
    qtbot.addWidget(d)
    assert not d.combo.isEnabled() and d.info.text() == "no cameras" and not d.timer.isActive()
    d.refresh()
    assert d.view.image is None
    bridge.close()
    with pytest.raises(ValueError, match="depth range"):
        CameraDock(bridge, CAMERAS, depth_range=(5.0, 5.0))
    with pytest.raises(ValueError, match="refresh"):
        CameraDock(bridge, CAMERAS, interval_ms=1)


def test_the_main_window_has_the_dock_only_with_cameras(qtbot, embedded, tmp_path):
    from vilma.gui.main_window import MainWindow

    w = MainWindow(embedded, refresh_ms=100, record_dir=tmp_path)
    qtbot.addWidget(w)
    w.show()
    assert embedded.world_topics == () and w.camera_dock.isHidden() and w.camera_dock.info.text() == "no cameras"
    w.close()

    embedded.world_topics = CAMERAS  # as a scenario with a stereo camera's left eye would give
    w = MainWindow(embedded, refresh_ms=100, record_dir=tmp_path)
    qtbot.addWidget(w)
    w.show()
    assert not w.camera_dock.isHidden() and w.camera_dock.combo.count() == 2
    embedded.bus.publish(topic("camera/front_left"), red_square())
    qtbot.waitUntil(lambda: w.camera_dock.view.image is not None, timeout=5000)
    x, y, ww, h = SQUARE
    assert _rgb(w.camera_dock.view.image, x + ww // 2, y + h // 2) == (255, 0, 0)
    assert w.camera_dock.toggleViewAction() in w.menuBar().actions()[2].menu().actions()
    w.close()


def test_the_main_window_shows_what_the_3d_car_s_camera_sees(qtbot, tmp_path, screenshots):

    from tests.gui.conftest import SPEED, shown_window
    from vilma.gui.backend import Embedded
    from vilma.scenario.fields import load_yaml
    from vilma.scenario.spec import parse_scenario

    data, src = load_yaml("plant: mujoco\ncameras: {stereo: {width: 320, height: 240, rate_hz: 10}}\n"
                          "world:\n  boxes: [{pos: [15, 0, 1], size: [0.5, 1.5, 1], rgba: [1, 0, 0, 1]}]\n"
                          "  cones: [{pos: [8, 2.5]}, {pos: [8, -2.5]}, {pos: [12, 2.5]}, {pos: [12, -2.5]}]\n"
                          "task: {speed: 0.0001}\n", "camera.yaml")
    backend = Embedded(parse_scenario(data, src), speed=SPEED)
    try:
        w = shown_window(qtbot, backend, tmp_path)
        d = w.camera_dock
        assert d.isVisible() and d.combo.currentText() == "camera/front_left"
        qtbot.waitUntil(lambda: d.view.image is not None, timeout=10_000)
        img = d.view.image
        assert (img.width(), img.height()) == (320, 240)
        # the red box stands straight ahead: in the centre column, from its top to its foot as the pinhole puts them
        red = [y for y in range(240) if _rgb(img, 160, y)[0] > 2 * _rgb(img, 160, y)[1] + 20]
        cam = backend.scenario.sim.cameras[0]
        height = backend.vehicle.suspension.cg_height + cam.position[2]
        ahead = 15.0 - 0.5 - cam.position[0]
        assert min(red) == pytest.approx(120 - cam.focal_px * (2.0 - height) / ahead, abs=2)
        assert max(red) == pytest.approx(120 + cam.focal_px * height / ahead, abs=2)
        d.resize(520, 420)
        assert d.grab().save(str(screenshots / "gui-camera.png"))
        w.close()
    finally:
        backend.close()
