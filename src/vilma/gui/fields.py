"""Reading numbers typed into the GUI: a clear one-line refusal instead of an exception reaching Qt."""

from __future__ import annotations

import math


class FieldError(ValueError):
    """A value typed into a field that cannot be used; the message says which field and how to fix it."""


def parse_number(text: str, field: str, low: float = -math.inf, high: float = math.inf,
                 low_open: bool = False) -> float:
    """``text`` as a finite float within ``[low, high]`` (``(low, high]`` if ``low_open``).

    Raises:
        FieldError: not a number, not finite, or out of range; the message names ``field``.
    """
    s = text.strip().replace(",", ".") if text.count(",") == 1 and "." not in text else text.strip()
    if not s:
        raise FieldError(f"{field}: empty; type a number")
    try:
        v = float(s)
    except ValueError:
        raise FieldError(f"{field}: {text.strip()!r} is not a number; type a number like 2.5") from None
    if not math.isfinite(v):
        raise FieldError(f"{field}: {text.strip()!r} is not finite; type a finite number")
    below = v <= low if low_open else v < low
    if below or v > high:
        lo = "(" if low_open else "["
        raise FieldError(f"{field}: {v:g} is out of range {lo}{low:g}, {high:g}]; type a value inside it")
    return v
