"""The shared test helpers keep their promises: a test leaves no process behind."""

from __future__ import annotations

import signal
import sys

import pytest

from tests.conftest import Processes


def test_the_processes_a_test_starts_are_ended_when_it_fails():
    with pytest.raises(AssertionError), Processes() as processes:
        idle = processes.start(sys.executable, "-c", "import time; time.sleep(600)")
        raise AssertionError("the test failed")
    assert idle.returncode == -signal.SIGKILL  # killed and reaped, not left running


def test_a_process_that_ended_keeps_its_exit_code_and_its_pipe_is_closed():
    with Processes() as processes:
        done = processes.start(sys.executable, "-c", "print('hello')")
        done.wait(timeout=60)
    assert done.returncode == 0 and done.stdout.closed
