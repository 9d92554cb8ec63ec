"""What every order to the driver on ``driver/cmd`` is checked for, whatever its action: its speed, its goal and its
points (:class:`~vilma.bus.nodes.DriverNode`, :mod:`vilma.bus.plan_node`)."""

from __future__ import annotations

import math

import numpy as np

MAX_REACH = 100_000.0
"""Farthest an order's goal and points may be from the car [m] (from the origin before the driver knows where the car
is): a drive's, not a continent's."""


def order_speed(speed: float, top: float, stop: bool = False) -> float:
    """An order's ``speed`` [m/s], checked: above zero (zero too, to ``stop``) and at most the car's ``top`` speed.

    Raises:
        ValueError: any other speed (NaN and infinities too), in one line.
    """
    if not ((speed >= 0 if stop else speed > 0) and speed <= top):
        raise ValueError(f"speed {speed!r} m/s: give {'0 (a stop) or more' if stop else 'a speed above 0'}, up to "
                         f"the car's top speed, {top:.3g} m/s")
    return speed


def check_goal(x: float, y: float, car: tuple[float, float]) -> None:
    """Raises ValueError unless ``(x, y)`` [m] is a point within :data:`MAX_REACH` of the car at ``car``."""
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"goal x={x!r} y={y!r} is not a point; give finite x and y [m]")
    dx, dy = x - car[0], y - car[1]
    if max(abs(dx), abs(dy)) > MAX_REACH or math.hypot(dx, dy) > MAX_REACH:  # (each first: hypot could overflow)
        raise ValueError(f"goal {[x, y]} is over {MAX_REACH:g} m from the car; give a nearer goal")


def check_points(xy: np.ndarray, speeds: np.ndarray | None, car: tuple[float, float], top: float, what: str) -> None:
    """Raises ValueError unless the points ``xy`` (n, 2) [m] of a ``what`` (path, route) are 2 or more distinct finite
    ones within :data:`MAX_REACH` of the car at ``car``, and their ``speeds`` [m/s] (None: none) from 0 to ``top``."""
    finite = np.isfinite(xy).all()
    if finite and len(xy) and (np.abs(xy - car).max() > MAX_REACH or np.hypot(*(xy - car).T).max() > MAX_REACH):
        raise ValueError(f"{what} points over {MAX_REACH:g} m from the car; send the {what} near the car")
    if not finite or not (np.hypot(*np.diff(xy, axis=0).T) > 1e-9).any():
        raise ValueError(f"{what} points must be 2 or more distinct finite [x, y] pairs [m]")
    if speeds is not None and not ((speeds >= 0) & (speeds <= top)).all():
        raise ValueError(f"{what} speeds must be from 0 to the car's top speed, {top:.3g} m/s")
