"""The garbage collector while a command starts: idle, then told that what the start made lives on.

A command's start makes some 150 000 objects that live as long as the process (modules, numba's typing registries
and compiled code): CPython's collector, counting them as they come, scans them again and again while they pile up
and finds nothing to free: 60-70 ms of a 0.45 s ``vilma run`` (``benchmarks/whole_command.py``). So a batch command
starts with the collector's first threshold out of reach (:func:`starting`); after its first run (before any run of a
paced batch, a fleet or a Dask sweep), :func:`started` moves everything alive to the permanent generation
(:func:`gc.freeze`: later collections skip it) and restores the thresholds, so a long batch collects as usual. A
command that never calls :func:`started` still collects, every :data:`STARTING` new objects.
"""

from __future__ import annotations

import gc

STARTING = 1_000_000
"""The collector's first threshold while a command starts (new container objects between collections)."""
_usual: tuple[int, int, int] | None = None


def starting() -> None:
    """Hold the collector off while the command starts (until :func:`started`)."""
    global _usual
    if _usual is None:
        _usual = gc.get_threshold()
        gc.set_threshold(STARTING, *_usual[1:])


def started() -> None:
    """The start is over: what it made is frozen out of later collections and the usual thresholds are back (once;
    nothing if :func:`starting` was not called)."""
    global _usual
    if _usual is not None:
        gc.freeze()
        gc.set_threshold(*_usual)
        _usual = None
