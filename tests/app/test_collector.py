"""The garbage collector while a batch command starts (:mod:`vilma.app.collector`)."""

from __future__ import annotations

import gc

import pytest
from rich.console import Console

from vilma.app import batch, collector


@pytest.fixture
def usual():
    """The collector's thresholds before the test, back after it, nothing frozen."""
    before = gc.get_threshold()
    yield before
    collector.started()
    gc.unfreeze()
    gc.set_threshold(*before)


def test_starting_holds_the_collector_off_and_started_brings_it_back(usual):
    collector.starting()
    collector.starting()  # (twice: the usual thresholds are still the ones to come back to)
    assert gc.get_threshold() == (collector.STARTING, *usual[1:])
    made = [[] for _ in range(1000)]  # objects of the start, alive when it ends
    collector.started()
    assert gc.get_threshold() == usual and gc.get_freeze_count() >= len(made)
    frozen = gc.get_freeze_count()
    collector.started()  # (once only)
    assert gc.get_freeze_count() == frozen


def test_started_without_starting_changes_nothing(usual):
    collector.started()
    assert gc.get_threshold() == usual and gc.get_freeze_count() == 0


def test_a_batch_collects_as_usual_after_its_first_run(usual, tmp_path):
    collector.starting()
    jobs = batch.plan(["pi_ff_speed_5"], ["duration=1,2"])
    seen = []
    batch.run_all(jobs, tmp_path, None, Console(quiet=True), lambda _: seen.append(gc.get_threshold()) or (),
                  record=False, plots=False)
    assert seen == [(collector.STARTING, *usual[1:]), usual]  # as the first run started, as the second did
    assert gc.get_freeze_count() > 0
