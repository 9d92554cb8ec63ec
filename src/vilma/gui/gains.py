"""A form that edits the fields of a frozen parameter dataclass (controller gains), checked on apply."""

from __future__ import annotations

import dataclasses
from typing import Any

from PySide6.QtWidgets import QCheckBox, QFormLayout, QLineEdit, QWidget

from vilma.gui.fields import FieldError, parse_number


class ParamsEditor(QWidget):
    """One row per field of a parameter dataclass: numbers in line edits, flags in check boxes."""

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.form = QFormLayout(self)
        self.form.setContentsMargins(0, 0, 0, 0)
        self.params: Any = None
        self.editors: dict[str, QLineEdit | QCheckBox] = {}

    def set_params(self, params: Any) -> None:
        """Show the fields of ``params`` (a dataclass instance)."""
        while self.form.rowCount():
            self.form.removeRow(0)
        self.params, self.editors = params, {}
        for f in dataclasses.fields(params):
            v = getattr(params, f.name)
            if isinstance(v, bool):
                w: QLineEdit | QCheckBox = QCheckBox(self)
                w.setChecked(v)
            elif isinstance(v, int | float | str):
                w = QLineEdit(f"{v:g}" if isinstance(v, float) else str(v), self)
            else:
                continue
            self.editors[f.name] = w
            self.form.addRow(f.name, w)

    def values(self) -> Any:
        """The edited parameters (a new dataclass instance).

        Raises:
            FieldError: a field that is not a number, or that the parameters refuse (their own check).
        """
        name = type(self.params).__name__
        changes: dict[str, Any] = {}
        for field, w in self.editors.items():
            old = getattr(self.params, field)
            if isinstance(w, QCheckBox):
                changes[field] = w.isChecked()
            elif isinstance(old, int):
                v = parse_number(w.text(), f"{name}.{field}")
                if v != int(v):
                    raise FieldError(f"{name}.{field}: {v:g} must be a whole number")
                changes[field] = int(v)
            elif isinstance(old, float):
                changes[field] = parse_number(w.text(), f"{name}.{field}")
            else:
                changes[field] = w.text().strip()
        try:
            return dataclasses.replace(self.params, **changes)
        except (ValueError, TypeError) as e:
            raise FieldError(f"{name}: {e}") from None
