"""The waypoint table: X, Y [m] and an optional speed [m/s] per row; add, insert, delete, paste.

Every cell is checked when it is written: a value that is not a finite
number (or a negative speed) is refused with :attr:`WaypointModel.refused`
and the cell keeps its old value.
"""

from __future__ import annotations

import re

import numpy as np
from PySide6.QtCore import QAbstractTableModel, QModelIndex, QPersistentModelIndex, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QGuiApplication, QKeySequence, QShortcut
from PySide6.QtWidgets import QAbstractItemView, QHBoxLayout, QPushButton, QTableView, QVBoxLayout, QWidget

from vilma.gui.fields import FieldError, parse_number
from vilma.trajectory import Trajectory

COLUMNS = ("X [m]", "Y [m]", "Speed [m/s]")
ACTIVE = QColor(255, 215, 0)

_Index = QModelIndex | QPersistentModelIndex


class WaypointModel(QAbstractTableModel):
    """Rows of ``[x, y, speed or None]``; the active waypoint (the driver's target) is highlighted."""

    refused = Signal(str)
    """A cell edit or a paste was refused: the message says why."""
    changed = Signal()
    """The points changed (edit, load, insert, delete)."""

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._rows: list[list[float | None]] = []
        self.active_row = -1
        self.dataChanged.connect(lambda *_: self.changed.emit())
        self.modelReset.connect(self.changed.emit)
        self.rowsInserted.connect(lambda *_: self.changed.emit())
        self.rowsRemoved.connect(lambda *_: self.changed.emit())

    # -- Qt model interface --------------------------------------------------------------------------------

    def rowCount(self, parent: _Index = QModelIndex()) -> int:  # noqa: N802 (Qt override)
        return 0 if parent.isValid() else len(self._rows)

    def columnCount(self, parent: _Index = QModelIndex()) -> int:  # noqa: N802 (Qt override)
        return 0 if parent.isValid() else len(COLUMNS)

    def headerData(self, section: int, orientation: Qt.Orientation, role: int = Qt.ItemDataRole.DisplayRole):  # noqa: N802 (Qt override)
        if role != Qt.ItemDataRole.DisplayRole:
            return None
        return COLUMNS[section] if orientation == Qt.Orientation.Horizontal else str(section + 1)

    def flags(self, index: _Index) -> Qt.ItemFlag:
        return Qt.ItemFlag.ItemIsEnabled | Qt.ItemFlag.ItemIsSelectable | Qt.ItemFlag.ItemIsEditable

    def data(self, index: _Index, role: int = Qt.ItemDataRole.DisplayRole):
        if not index.isValid():
            return None
        if role in (Qt.ItemDataRole.DisplayRole, Qt.ItemDataRole.EditRole):
            v = self._rows[index.row()][index.column()]
            return "" if v is None else f"{v:.6g}" if role == Qt.ItemDataRole.EditRole else f"{v:.3f}"
        if role == Qt.ItemDataRole.BackgroundRole and index.row() == self.active_row:
            return QBrush(ACTIVE)
        return None

    def setData(self, index: _Index, value, role: int = Qt.ItemDataRole.EditRole) -> bool:  # noqa: N802 (Qt override)
        if not index.isValid() or role != Qt.ItemDataRole.EditRole:
            return False
        row, col = index.row(), index.column()
        try:
            v = self._cell(str(value), row, col)
        except FieldError as e:
            self.refused.emit(str(e))
            return False
        self._rows[row][col] = v
        self.dataChanged.emit(index, index)
        return True

    @staticmethod
    def _cell(text: str, row: int, col: int, where: str = "") -> float | None:
        where = where or f"waypoint {row + 1}, {COLUMNS[col]}"
        if col == 2:
            if not text.strip():
                return None
            return parse_number(text, where, 0.0)
        return parse_number(text, where)

    # -- editing -------------------------------------------------------------------------------------------

    def insert_rows(self, row: int, count: int = 1) -> None:
        """Insert ``count`` rows before ``row`` (``len``: append), each a copy of the row before (or 0, 0)."""
        row = max(0, min(row, len(self._rows)))
        base = list(self._rows[row - 1]) if row > 0 else [0.0, 0.0, None]
        self.beginInsertRows(QModelIndex(), row, row + count - 1)
        for _ in range(count):
            self._rows.insert(row, list(base))
        self.endInsertRows()

    def remove_rows(self, rows: list[int]) -> None:
        """Delete the rows ``rows`` (any order)."""
        for r in sorted(set(rows), reverse=True):
            if 0 <= r < len(self._rows):
                self.beginRemoveRows(QModelIndex(), r, r)
                del self._rows[r]
                self.endRemoveRows()

    def paste_text(self, text: str, row: int) -> int:
        """Insert rows parsed from ``text`` before ``row``: one per line, ``x y [speed]`` separated by tabs,
        commas, semicolons or spaces; a header line is skipped. Returns the rows added.

        Raises:
            FieldError: a line that is not 2 or 3 numbers (nothing is inserted).
        """
        rows: list[list[float | None]] = []
        lines = [ln for ln in text.splitlines() if ln.strip()]
        for n, line in enumerate(lines, start=1):
            tokens = [t for t in re.split(r"[\t,; ]+", line.strip()) if t]
            if n == 1 and tokens and not _is_number(tokens[0]):
                continue  # a header such as "x,y,speed"
            if len(tokens) not in (2, 3):
                raise FieldError(f"paste line {n}: {line.strip()!r} has {len(tokens)} values; give 'x y' or "
                                 "'x y speed' per line")
            rows.append([self._cell(t, 0, c, f"paste line {n}, {COLUMNS[c]}") for c, t in enumerate(tokens)] +
                        ([None] if len(tokens) == 2 else []))
        if not rows:
            raise FieldError("paste: the clipboard holds no points; copy lines of 'x y' or 'x y speed'")
        row = max(0, min(row, len(self._rows)))
        self.beginInsertRows(QModelIndex(), row, row + len(rows) - 1)
        self._rows[row:row] = rows
        self.endInsertRows()
        return len(rows)

    def set_trajectory(self, path: Trajectory) -> None:
        """Replace every row with the points (and speeds) of ``path``."""
        self.beginResetModel()
        speeds = path.speed.tolist() if path.speed is not None else [None] * len(path)
        self._rows = [[float(x), float(y), s] for (x, y), s in zip(path.xy.tolist(), speeds, strict=True)]
        self.active_row = -1
        self.endResetModel()

    def trajectory(self) -> Trajectory:
        """The rows as a trajectory; speeds only if every row has one.

        Raises:
            ValueError: the table is empty.
        """
        if not self._rows:
            raise ValueError("the waypoint table is empty; add rows or load a file")
        xy = np.array([r[:2] for r in self._rows], dtype=float)
        speeds = [r[2] for r in self._rows]
        return Trajectory(xy, None if any(s is None for s in speeds) else np.array(speeds, dtype=float))

    def set_active(self, row: int) -> None:
        """Highlight ``row`` (-1: none)."""
        if row == self.active_row:
            return
        old, self.active_row = self.active_row, row
        for r in (old, row):
            if 0 <= r < len(self._rows):
                self.dataChanged.emit(self.index(r, 0), self.index(r, len(COLUMNS) - 1),
                                      [Qt.ItemDataRole.BackgroundRole])


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


class WaypointTable(QWidget):
    """The table view with Add, Insert, Delete and Paste (also Ctrl+V)."""

    message = Signal(str)
    """Something to tell the user (a refused edit or paste)."""

    def __init__(self, model: WaypointModel | None = None, parent=None) -> None:
        super().__init__(parent)
        self.model = model or WaypointModel(self)
        self.view = QTableView(self)
        self.view.setModel(self.model)
        self.view.setSelectionBehavior(QAbstractItemView.SelectionBehavior.SelectRows)
        self.view.horizontalHeader().setStretchLastSection(True)
        self.model.refused.connect(self.message)
        buttons = QHBoxLayout()
        for text, slot, tip in (("Add", self.add_row, "append a row (a copy of the last)"),
                                ("Insert", self.insert_row, "insert a row before the selected one"),
                                ("Delete", self.delete_rows, "delete the selected rows"),
                                ("Paste", self.paste, "insert 'x y [speed]' lines from the clipboard")):
            b = QPushButton(text, self)
            b.setToolTip(tip)
            b.clicked.connect(slot)
            buttons.addWidget(b)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addLayout(buttons)
        lay.addWidget(self.view)
        QShortcut(QKeySequence.StandardKey.Paste, self.view, self.paste)
        self.model.modelReset.connect(lambda: self.view.scrollToTop())

    def _current(self) -> int:
        rows = self.view.selectionModel().selectedRows()
        return min(r.row() for r in rows) if rows else -1

    def add_row(self) -> None:
        """Append a row."""
        self.model.insert_rows(self.model.rowCount())

    def insert_row(self) -> None:
        """Insert a row before the selected one (or at the top)."""
        self.model.insert_rows(max(self._current(), 0))

    def delete_rows(self) -> None:
        """Delete the selected rows."""
        rows = [r.row() for r in self.view.selectionModel().selectedRows()]
        if not rows:
            self.message.emit("Delete: select the rows to delete first")
            return
        self.model.remove_rows(rows)

    def paste(self) -> None:
        """Insert the clipboard's lines before the selected row (or at the end)."""
        row = self._current()
        try:
            n = self.model.paste_text(QGuiApplication.clipboard().text(),
                                      row if row >= 0 else self.model.rowCount())
        except FieldError as e:
            self.message.emit(str(e))
            return
        self.message.emit(f"pasted {n} waypoints")

    def highlight(self, row: int) -> None:
        """Highlight the active waypoint and keep it in sight."""
        self.model.set_active(row)
        if 0 <= row < self.model.rowCount():
            self.view.scrollTo(self.model.index(row, 0))
