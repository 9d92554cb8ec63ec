"""The check a frozen parameter dataclass runs when made: its numbers finite, some positive, none negative."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Collection


def check_numbers(params: object, what: str, positive: Collection[str] = (),
                  non_negative: bool | Collection[str] = False) -> None:
    """Raise ValueError naming the first number field of ``params`` (``what``: whose) that is not finite, or not
    > 0 when named in ``positive``, or negative with ``non_negative`` (True: any field; else those named); a tuple
    field is checked element-wise."""
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        for v in value if isinstance(value, tuple) else (value,):
            if isinstance(v, bool) or not isinstance(v, int | float):
                continue
            at_least_zero = non_negative if isinstance(non_negative, bool) else f.name in non_negative
            need = "> 0" if f.name in positive else ">= 0" if at_least_zero else ""
            if not math.isfinite(v) or (need == "> 0" and v <= 0) or (need == ">= 0" and v < 0):
                raise ValueError(f"{what} {f.name} must be a finite number{' ' + need if need else ''}, "
                                 f"got {value!r}")
