"""The waypoint table model and view: edits checked cell by cell, add / insert / delete / paste."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import Qt
from PySide6.QtGui import QGuiApplication
from PySide6.QtWidgets import QApplication, QLineEdit

from vilma.gui.waypoints import WaypointTable
from vilma.trajectory import Trajectory


def _table(qtbot, points=((0.0, 0.0), (1.0, 2.0), (3.0, 4.0))) -> WaypointTable:
    t = WaypointTable()
    qtbot.addWidget(t)
    t.model.set_trajectory(Trajectory.from_points(points))
    return t


def test_bad_cells_are_refused_with_a_message_and_keep_their_value(qtbot):
    t = _table(qtbot)
    m = t.model
    messages = []
    t.message.connect(messages.append)
    for text, col in (("abc", 0), ("nan", 1), ("inf", 0), ("", 0), ("-3", 2)):
        assert not m.setData(m.index(1, col), text)
    assert len(messages) == 5
    assert "waypoint 2, X [m]" in messages[0] and "not a number" in messages[0]
    assert "out of range" in messages[-1]
    assert np.array_equal(m.trajectory().xy, [[0, 0], [1, 2], [3, 4]])
    assert m.setData(m.index(1, 0), " 7.5 ") and m.trajectory().xy[1, 0] == 7.5


def test_editing_through_the_view_refuses_bad_text(qtbot):
    t = _table(qtbot)
    t.show()
    messages = []
    t.message.connect(messages.append)
    idx = t.model.index(0, 1)
    t.view.setCurrentIndex(idx)
    t.view.edit(idx)
    QApplication.processEvents()
    editor = t.view.findChild(QLineEdit)
    editor.selectAll()
    qtbot.keyClicks(editor, "1e999x")
    qtbot.keyClick(editor, Qt.Key.Key_Return)
    qtbot.waitUntil(lambda: bool(messages))
    assert messages and "not a number" in messages[-1]
    assert t.model.trajectory().xy[0, 1] == 0.0


def test_speeds_count_only_when_every_row_has_one(qtbot):
    t = _table(qtbot)
    m = t.model
    assert m.trajectory().speed is None
    for r in range(3):
        assert m.setData(m.index(r, 2), "2.5")
    assert np.array_equal(m.trajectory().speed, [2.5, 2.5, 2.5])


def test_add_insert_delete_rows(qtbot):
    t = _table(qtbot)
    m = t.model
    t.add_row()
    assert m.rowCount() == 4 and np.array_equal(m.trajectory().xy[-1], [3, 4])  # a copy of the last
    t.view.selectRow(1)
    t.insert_row()
    assert m.rowCount() == 5 and np.array_equal(m.trajectory().xy[1], [0, 0])  # a copy of the row before
    t.view.clearSelection()
    t.view.selectRow(0)
    t.delete_rows()
    assert m.rowCount() == 4


def test_paste_from_the_clipboard_inserts_rows_and_refuses_a_bad_line(qtbot):
    t = _table(qtbot, ((0.0, 0.0),))
    messages = []
    t.message.connect(messages.append)
    QGuiApplication.clipboard().setText("x\ty\tspeed\n10\t20\t3\n30, 40, 4\n")
    t.paste()
    assert np.array_equal(t.model.trajectory().xy, [[0, 0], [10, 20], [30, 40]])
    QGuiApplication.clipboard().setText("1 2\n3 four\n")
    t.paste()
    assert "paste line 2" in messages[-1] and t.model.rowCount() == 3  # nothing inserted
    QGuiApplication.clipboard().setText("1 2 3 4\n")
    t.paste()
    assert "4 values" in messages[-1]
