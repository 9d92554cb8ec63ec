"""The "Camera" dock: the latest image of one of the 3D plant's cameras, chosen in a combo box.

The bus thread only stores the latest message of each camera topic (:class:`~vilma.gui.bridge.BusBridge`);
the dock's timer converts the chosen one when it is new (a colour image as it is, a depth image as grey
levels over a fixed range) and scales it to the view, so at most one image a refresh is converted.
"""

from __future__ import annotations

import logging

import numpy as np
from PySide6.QtCore import QSize, Qt, QTimer
from PySide6.QtGui import QImage, QPixmap
from PySide6.QtWidgets import QComboBox, QDockWidget, QLabel, QSizePolicy, QVBoxLayout, QWidget

from vilma.core.messages import Image
from vilma.gui.bridge import BusBridge
from vilma.record.world_schemas import DEPTH, image_problem

log = logging.getLogger(__name__)

DEPTH_RANGE = (0.0, 50.0)
"""Depths shown white (near) to black (far, and where nothing is in range) [m]."""


def depth_levels(depth: np.ndarray, near: float, far: float) -> np.ndarray:
    """Depths [m] as grey levels, same shape, uint8: 255 at ``near`` down to 0 at ``far`` and beyond (inf)."""
    d = np.nan_to_num(depth, nan=far, posinf=far, neginf=near)
    return np.round(255.0 * (far - np.clip(d, near, far)) / (far - near)).astype(np.uint8)


def qimage_of(msg: Image, depth_range: tuple[float, float] = DEPTH_RANGE) -> QImage:
    """A well-formed :class:`~vilma.core.messages.Image` as a QImage (RGB888, or Grayscale8 for depth)."""
    rows = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.step)
    if msg.encoding == DEPTH:
        depth = rows[:, :4 * msg.width].copy().view("<f4")
        grey = np.ascontiguousarray(depth_levels(depth, *depth_range))
        return QImage(grey.data, msg.width, msg.height, msg.width, QImage.Format.Format_Grayscale8).copy()
    rgb = np.ascontiguousarray(rows[:, :3 * msg.width])
    return QImage(rgb.data, msg.width, msg.height, 3 * msg.width, QImage.Format.Format_RGB888).copy()


class ImageView(QLabel):
    """One image scaled to fit the label, its aspect ratio kept, centred on black."""

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.image: QImage | None = None
        """The image shown, at its own size."""
        self.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)
        self.setStyleSheet("QLabel { background: black; }")

    def sizeHint(self) -> QSize:  # noqa: N802 (Qt override): half a 640x480 image, whatever the pixmap
        return QSize(320, 240)

    def minimumSizeHint(self) -> QSize:  # noqa: N802 (Qt override): the pixmap follows the view, not the reverse
        return QSize(160, 120)

    def set_image(self, image: QImage | None) -> None:
        """Show ``image`` (None: nothing)."""
        self.image = image
        self._scale()

    def _scale(self) -> None:
        if self.image is None:
            self.clear()
        else:
            self.setPixmap(QPixmap.fromImage(self.image).scaled(
                self.size(), Qt.AspectRatioMode.KeepAspectRatio, Qt.TransformationMode.FastTransformation))

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt override)
        super().resizeEvent(event)
        self._scale()


class CameraDock(QDockWidget):
    """Camera: the latest image of the camera topic chosen (see the module docstring).

    Args:
        bridge: where the latest messages are (subscribed to ``topics``).
        topics: camera topics (``camera/<name>``, ``camera/<name>/depth``); none: the dock says "no cameras".
        interval_ms: refresh period [ms].
        depth_range: ``(near, far)`` [m] of the depth grey scale.
    """

    def __init__(self, bridge: BusBridge, topics: tuple[str, ...] = (), interval_ms: int = 100,
                 depth_range: tuple[float, float] = DEPTH_RANGE, parent=None) -> None:
        super().__init__("Camera", parent)
        self.setObjectName("camera")
        near, far = depth_range
        if not 10 <= interval_ms <= 60_000:
            raise ValueError(f"camera refresh must be 10..60000 ms, got {interval_ms}")
        if not 0 <= near < far < float("inf"):
            raise ValueError(f"depth range must be 0 <= near < far < inf [m], got {near}, {far}")
        self.bridge, self.depth_range = bridge, depth_range
        self.topics = tuple(t for t in topics if t.startswith("camera/"))
        self._shown: Image | None = None
        self._warned: set[str] = set()
        body = QWidget()
        lay = QVBoxLayout(body)
        self.combo = QComboBox(body)
        self.combo.addItems(list(self.topics))
        self.combo.setEnabled(bool(self.topics))
        self.combo.currentTextChanged.connect(self._chosen)
        self.view = ImageView(body)
        self.info = QLabel("waiting for images" if self.topics else "no cameras", body)
        lay.addWidget(self.combo)
        lay.addWidget(self.view, 1)
        lay.addWidget(self.info)
        self.setWidget(body)
        self.timer = QTimer(self)
        self.timer.timeout.connect(self.refresh)
        if self.topics:
            self.timer.start(interval_ms)

    @property
    def topic(self) -> str:
        """The camera topic shown ("" without cameras)."""
        return self.combo.currentText()

    def _chosen(self, _: str) -> None:
        self._shown = None
        self.view.set_image(None)
        self.info.setText("waiting for images")
        self.refresh()

    def refresh(self) -> None:
        """Show the chosen camera's latest image if it is new; a malformed one is dropped with a warning."""
        msg = self.bridge.latest.get(self.topic) if self.topics else None
        if msg is None or msg is self._shown:
            return
        self._shown = msg
        problem = image_problem(msg)
        if problem is not None:
            if self.topic not in self._warned:
                self._warned.add(self.topic)
                log.warning("camera %s: %s; image dropped", self.topic, problem)
            self.info.setText(f"bad image dropped: {problem}")
            return
        self.view.set_image(qimage_of(msg, self.depth_range))
        what = f"grey {self.depth_range[0]:g} (white)..{self.depth_range[1]:g} m" if msg.encoding == DEPTH else "colour"
        self.info.setText(f"{msg.width}x{msg.height} {msg.encoding} ({what}), t {msg.stamp_ns * 1e-9:.2f} s")
