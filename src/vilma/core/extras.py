"""The optional parts of vilma and the packages each needs: a command that needs a missing one says which
extra to install (``pip install 'vilma[3d]'``), in one line, before it starts."""

from __future__ import annotations

import importlib

EXTRAS = {"gui": ("PySide6", "pyqtgraph"), "3d": ("mujoco",), "foxglove": ("foxglove",),
          "roads": ("commonroad", "commonroad_route_planner", "commonroad_dc"),
          "sweep": ("distributed", "pandas", "pyarrow", "optuna")}
"""The extras of ``pyproject.toml`` and the modules each brings; ``vilma[all]`` has them all."""


class MissingExtraError(ImportError):
    """An optional part of vilma is not installed."""


def require(extra: str, what: str) -> None:
    """Import the modules of ``extra`` (:data:`EXTRAS`), or raise :class:`MissingExtraError` saying that ``what`` (the
    part of vilma asked for) needs it and how to install it."""
    for module in EXTRAS[extra]:
        try:
            importlib.import_module(module)
        except ImportError:
            raise MissingExtraError(f"{what} needs the '{extra}' extra ({module} is not installed): "
                               f"pip install 'vilma[{extra}]'") from None
