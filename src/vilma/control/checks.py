"""The check every controller's parameters pass when made: finite numbers, none negative, periods and the
named ones positive, search windows of at least one segment."""

from __future__ import annotations

import dataclasses
import math


def check_params(params: object, name: str, positive: tuple[str, ...] = ()) -> None:
    """Raise ValueError naming the first field of ``params`` (controller ``name``) that is out of range."""
    for f in dataclasses.fields(params):
        v = getattr(params, f.name)
        if isinstance(v, bool) or not isinstance(v, int | float):
            continue
        if f.name == "window" and v < 1:
            raise ValueError(f"{name} window must be at least 1 segment, got {v!r}")
        must_be_positive = f.name == "period" or f.name in positive
        if not math.isfinite(v) or v < 0 or (must_be_positive and v == 0):
            raise ValueError(f"{name} {f.name} must be a finite number {'> 0' if must_be_positive else '>= 0'}, "
                             f"got {v!r}")
