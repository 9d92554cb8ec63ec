"""The check every controller's parameters pass when made: finite numbers, none negative, periods and the
named ones positive, search windows of at least one segment."""

from __future__ import annotations

from vilma.core.checks import check_numbers


def check_params(params: object, name: str, positive: tuple[str, ...] = ()) -> None:
    """Raise ValueError naming the first field of ``params`` (controller ``name``) that is out of range."""
    if getattr(params, "window", 1) < 1:
        raise ValueError(f"{name} window must be at least 1 segment, got {params.window!r}")
    check_numbers(params, name, positive=("period", *positive), non_negative=True)
