"""Controllers by name: one registry the driver, the compiled loop, scenario files, the GUI and the bus read.

A controller file registers a :class:`ControllerType`: its parameters (a frozen dataclass with a ``period``
[s]), its constants (a NamedTuple that compiled code reads, made from the parameters and the car), the
initial values of its state array, and its compiled step. Compiled code calls the step through the stubs
:func:`speed_step` and :func:`path_step`: each registration adds a numba overload of the stub matching its
constants' NamedTuple class, so callers compile (and cache) for the chosen controller without naming it.

Uniform steps (``state`` a float64 array the controller owns, ``pa`` a path's
:class:`~vilma.trajectory.PathArrays`):

- speed: ``step(c, state, target, measured, steer) -> (mode, drive, brake, velocity_limit)``, speeds [m/s],
  ``steer`` the last front-wheel command [rad], ``mode`` a compiled longitudinal mode id
  (:data:`~vilma.vehicle.actuators.MODE_IDS`);
- path: ``step(c, state, pa, x, y, yaw, speed, yaw_rate) -> (steer [rad], passed_end)``, the pose of the
  centre of mass [m, rad], its speed [m/s] and yaw rate [rad/s]; ``passed_end`` asks for the final stop.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
from numba import types
from numba.extending import overload

from vilma.vehicle.params import VehicleParams

SPEED, PATH = "speed", "path"
"""The kinds of controller."""
BUNDLED = {SPEED: "vilma.control.speed", PATH: "vilma.control.path"}
"""Packages whose modules register the controllers vilma ships: each module is the controller of its name, of the
package's kind; imported when that controller is first asked for."""


def speed_step(c, state, target, measured, steer):
    """Compiled code only: the step of the speed controller whose constants are ``c``."""
    raise NotImplementedError("speed_step dispatches in compiled code only; call the controller's step")


def path_step(c, state, pa, x, y, yaw, speed, yaw_rate):
    """Compiled code only: the step of the path controller whose constants are ``c``."""
    raise NotImplementedError("path_step dispatches in compiled code only; call the controller's step")


@dataclass(frozen=True, slots=True)
class ControllerType:
    """A registered controller: what it takes and how it runs."""

    name: str
    """The name scenario files, the GUI and the bus use (``stanley``)."""
    kind: str
    """:data:`SPEED` or :data:`PATH`."""
    params: type
    """Its frozen parameter dataclass; made without arguments it gives the defaults; ``period`` [s]."""
    consts: type
    """The NamedTuple class of its compiled constants (one class per controller: dispatch matches on it)."""
    make_consts: Callable[[Any, VehicleParams], tuple]
    """``(params, vehicle) -> consts``."""
    state: tuple[float, ...]
    """Its state array after a reset."""
    step: Callable
    """Its compiled step, with the signature of its kind (module docstring)."""

    def make(self, vehicle: VehicleParams, params: Any = None) -> Controller:
        """This controller for ``vehicle`` with ``params`` (default: the defaults)."""
        return Controller(self, vehicle, self.params() if params is None else params)


class Controller:
    """A controller made for a car: its parameters, compiled constants and state, steppable from Python."""

    def __init__(self, ctype: ControllerType, vehicle: VehicleParams, params: Any) -> None:
        self.type, self.params = ctype, params
        self.period: float = params.period
        """Control period [s]."""
        self.consts = ctype.make_consts(params, vehicle)
        self.state = np.array(ctype.state, dtype=np.float64)
        """The state its step updates in place (the controller file says what each slot holds)."""

    def reset(self) -> None:
        """Start again: the state of a fresh controller."""
        self.state[:] = self.type.state

    def step(self, *args):
        """One control period: the compiled step on the constants and state, with the rest of its arguments."""
        return self.type.step(self.consts, self.state, *args)


_TYPES: dict[str, ControllerType] = {}


def register(kind: ControllerType) -> ControllerType:
    """Add ``kind`` to the registry and to the compiled dispatch of its kind; returns it.

    Raises:
        ValueError: the name is taken, the kind unknown, or the constants class not a NamedTuple of its own.
    """
    if kind.kind not in (SPEED, PATH):
        raise ValueError(f"controller {kind.name!r}: kind must be {SPEED!r} or {PATH!r}, got {kind.kind!r}")
    _import_bundled(kind.name)  # (one of vilma's own names is taken even before its first use)
    if kind.name in _TYPES:
        raise ValueError(f"controller {kind.name!r} is registered already; choose another name")
    if not hasattr(kind.consts, "_fields") or any(t.consts is kind.consts for t in _TYPES.values()):
        raise ValueError(f"controller {kind.name!r}: consts must be a NamedTuple class of its own")
    _overload(kind)
    _TYPES[kind.name] = kind
    return kind


def _overload(kind: ControllerType) -> None:
    """Make the stub of ``kind``'s kind call its step when given its constants."""
    cls, step = kind.consts, kind.step

    def ours(c) -> bool:
        return isinstance(c, types.BaseNamedTuple) and c.instance_class is cls

    if kind.kind == SPEED:
        @overload(speed_step)
        def _speed(c, state, target, measured, steer):
            if ours(c):
                return lambda c, state, target, measured, steer: step(c, state, target, measured, steer)
    else:
        @overload(path_step)
        def _path(c, state, pa, x, y, yaw, speed, yaw_rate):
            if ours(c):
                return lambda c, state, pa, x, y, yaw, speed, yaw_rate: step(c, state, pa, x, y, yaw, speed,
                                                                             yaw_rate)


@cache
def _bundled(kind: str) -> tuple[str, ...]:
    """The names of vilma's own controllers of ``kind``: the modules of its :data:`BUNDLED` package (so a new
    controller is a new file and nothing else), listed without importing them."""
    return tuple(m.name for m in pkgutil.iter_modules(importlib.import_module(BUNDLED[kind]).__path__))


def _import_bundled(name: str) -> None:
    """Import vilma's own controller ``name`` (registering it) if there is one and it is not registered yet (a
    module that registers it as it is imported is taken as imported)."""
    for kind in (SPEED, PATH):
        if name not in _TYPES and name in _bundled(kind):
            importlib.import_module(f"{BUNDLED[kind]}.{name}")


def names(kind: str | None = None) -> tuple[str, ...]:
    """The registered controllers' names (of one kind, or all), vilma's own among them, sorted."""
    kinds = (SPEED, PATH) if kind is None else (kind,)
    return tuple(sorted({n for n, t in _TYPES.items() if t.kind in kinds}.union(*(_bundled(k) for k in kinds))))


def controller_type(name: str, kind: str | None = None) -> ControllerType:
    """The controller registered as ``name`` (of ``kind`` if given); one of vilma's own is imported, and so
    registered, on its first use (a run imports the two it drives with, not every one).

    Raises:
        ValueError: no such controller, naming the ones there are.
    """
    _import_bundled(name)
    t = _TYPES.get(name)
    if t is None or (kind is not None and t.kind != kind):
        what = f"{kind} controller" if kind else "controller"
        raise ValueError(f"{what} {name!r} is unknown; use one of {', '.join(names(kind))}")
    return t
