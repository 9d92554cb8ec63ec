"""Batches: the notice of a run that compiles vilma's functions."""

from __future__ import annotations

import io
import re
import sys

import pytest
from rich.console import Console

from vilma.app import batch


def vilma_kernel_for_the_test(x):
    return x + 1


vilma_kernel_for_the_test.__module__ = "vilma.test_kernels"  # a function of vilma's, as numba's events see it


def test_a_run_on_a_warm_cache_says_nothing_of_compiling(tmp_path):
    console = Console(record=True, width=200)
    jobs = batch.plan(["pi_ff_speed_5"], ["duration=1"])
    batch.run_all(jobs, tmp_path / "first", None, console, record=False)  # compiled or loaded: now in this process
    console = Console(record=True, width=200)
    batch.run_all(jobs, tmp_path / "warm", None, console, record=False)
    assert batch.COMPILING not in console.export_text()


def test_a_command_says_once_that_it_compiles_when_numba_compiles_vilmas_functions(tmp_path):
    from numba import njit
    from numba.core.event import install_listener

    console = Console(record=True, width=200)  # not a terminal: the notice without a progress line
    compiling = batch._Compiling(console, batch._Bar(console, False))
    with install_listener("numba:compile", compiling):
        assert njit(lambda x: x + 1)(1) == 2  # numba's or a user's own: not vilma's, nothing said
        assert batch.COMPILING not in console.export_text(clear=False)
        for _ in range(2):  # compiled here each time: not cached
            assert njit(vilma_kernel_for_the_test)(1) == 2
    assert console.export_text().count(batch.COMPILING) == 1 and compiling.done == 2


def test_in_a_terminal_a_single_run_shows_the_bar_from_when_it_compiles(monkeypatch, tmp_path):
    from numba import njit

    from vilma.scenario.result import RunObserver

    class Compiles(RunObserver):
        def started(self, sim, log):
            assert njit(vilma_kernel_for_the_test)(1) == 2  # as a cold cache compiles: within the run

    monkeypatch.setattr(sys, "stdout", io.StringIO())  # (see below)
    console = Console(file=io.StringIO(), force_terminal=True, width=200)
    (r,) = batch.run_all(batch.plan(["pi_ff_speed_5"], ["duration=1"]), tmp_path / "run", None, console,
                         lambda _: (Compiles(),), record=False)
    assert r.passed is not None and (tmp_path / "run" / "metrics.json").is_file()
    assert console.file.getvalue().count(batch.COMPILING) == 1


def test_in_a_terminal_a_compiling_run_shows_what_numba_compiles_and_drops_the_line_after_it(monkeypatch):
    from numba import njit
    from numba.core.event import install_listener

    # the bar wraps sys.stdout while it shows, and numba's compile hands what sys.stdout is then to colorama, which
    # writes to it at exit: a stream of the test's own, not pytest's (closed by then)
    monkeypatch.setattr(sys, "stdout", io.StringIO())
    console = Console(file=io.StringIO(), force_terminal=True, width=200)
    bar = batch._Bar(console, False)
    compiling = batch._Compiling(console, bar)
    with bar, install_listener("numba:compile", compiling):
        assert bar.progress is None  # (a single run: no bar until it compiles)
        assert njit(vilma_kernel_for_the_test)(1) == 2
        (line,) = bar.progress.tasks
        assert compiling.done == 1 and "vilma_kernel_for_the_test" in str(line.description)
        compiling.finished()
        assert not bar.progress.tasks
    assert batch.COMPILING in console.file.getvalue()


def test_cars_interrupted_keep_the_waves_before_whole(monkeypatch, tmp_path):
    """A fleet interrupted in its second wave: the first wave's cars have their scorecard (a whole run each), the
    others none, and the line says how many are done."""
    from vilma.scenario import fleet

    monkeypatch.setattr(fleet, "WAVE", 2)
    waves = []
    wave = fleet._wave

    def second_interrupted(cars, loading):
        waves.append(cars)
        if len(waves) == 2:
            raise KeyboardInterrupt
        return wave(cars, loading)

    monkeypatch.setattr(fleet, "_wave", second_interrupted)
    jobs = batch.as_cars(batch.plan(["pi_ff_speed_5"], ["duration=1"]), 4)
    out = tmp_path / "o"
    said = rf"^interrupted: 2 of 4 cars done, partial files in {re.escape(str(out))}$"
    with pytest.raises(KeyboardInterrupt, match=said):
        batch.run_cars(jobs, out, batch.Quiet())
    dirs = batch.out_dirs(jobs, out)
    assert [(d / "metrics.json").exists() for d in dirs] == [True, True, False, False]
