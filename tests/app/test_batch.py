"""Batches: the compile notice of a first run on a cold numba cache."""

from __future__ import annotations

import io
import os
import subprocess
import sys

from rich.console import Console

from vilma.app import batch
from vilma.scenario.runner import run
from vilma.scenario.spec import load_scenario

COLD = "from vilma.app.batch import numba_cache_cold; print(numba_cache_cold())"


def test_an_empty_cache_is_cold(tmp_path):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}  # numba's cache folder, empty
    r = subprocess.run([sys.executable, "-c", COLD], env=env, capture_output=True, text=True, timeout=120, check=True)
    assert r.stdout == "True\n"


def test_after_a_compiled_run_the_cache_is_warm():
    run(load_scenario("pi_ff_speed_5", {"duration": "1"}))  # compiled (or loaded) in this process, cached on disk
    assert not batch.numba_cache_cold()
    r = subprocess.run([sys.executable, "-c", COLD], capture_output=True, text=True, timeout=120, check=True)
    assert r.stdout == "False\n"  # another process finds it on disk


def test_the_first_run_on_a_cold_cache_says_it_compiles(monkeypatch, tmp_path):
    console = Console(record=True, width=200)
    jobs = batch.plan(["pi_ff_speed_5"], ["duration=1"])
    monkeypatch.setattr(batch, "numba_cache_cold", lambda: True)
    batch.run_all(jobs, tmp_path / "cold", None, console, record=False)
    monkeypatch.setattr(batch, "numba_cache_cold", lambda: False)
    batch.run_all(jobs, tmp_path / "warm", None, console, record=False)
    assert console.export_text().count(batch.COMPILING) == 1


def test_a_compiling_first_run_shows_what_numba_compiles_and_drops_the_line_after_it():
    from numba import njit
    from numba.core.event import install_listener
    from rich.progress import Progress

    def vilma_kernel_for_the_test(x):  # named as a module of vilma's below
        return x + 1

    vilma_kernel_for_the_test.__module__ = "vilma.test_kernels"  # numba's own functions are not counted
    bar = Progress(console=Console(file=io.StringIO(), force_terminal=True, width=200), redirect_stdout=False,
                   redirect_stderr=False)  # numba sets colorama up on its first compile, on what stdout is then
    compiling = batch._Compiling(bar)
    with bar, install_listener("numba:compile", compiling):
        assert njit(vilma_kernel_for_the_test)(1) == 2  # compiled here: not cached
        (line,) = bar.tasks
        assert compiling.done == 1 and "vilma_kernel_for_the_test" in str(line.description)
        compiling.finished()
        assert not bar.tasks
