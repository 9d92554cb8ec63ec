"""``vilma up``: simulator and driver in one process, paced, ended by its duration or a signal."""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

from vilma.app import programs
from vilma.app.batch import BUNDLED
from vilma.scenario import load_scenario


def test_up_drives_paced_and_reports_each_second():
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "up", "course_30kmh_stanley", "--speed", "10",
                        "--duration", "6"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    lines = [line for line in r.stdout.splitlines() if line.startswith("t ")]
    assert [float(line.split()[1]) for line in lines] == [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]
    assert "follow" in lines[-1]
    rtf = float(lines[-1].split()[-3].rstrip("x"))
    assert 0 < rtf < 10.5  # paced: never faster than 10x real time (how close it gets is a benchmark's business)


@pytest.mark.slow
def test_up_stops_cleanly_on_sigint(processes):
    p = processes.vilma("up", "--speed", "1", stderr=subprocess.PIPE)
    first = p.stdout.readline()  # the banner: it runs
    assert first.startswith("vilma up:")
    p.stdout.readline()  # one status line: the loop is going
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)  # it stops (how fast is a benchmark's business)
    assert p.returncode == 0 and "Traceback" not in err


def test_a_task_the_driver_refuses_is_one_warning_and_the_drive_goes_on(tmp_path, caplog):
    (tmp_path / "here.yaml").write_text("task: {go_to: [0, 0], speed: 5}\n")  # where the car starts
    lines: list[str] = []
    assert programs.up(load_scenario(tmp_path / "here.yaml"), 50.0, 1.0, lines.append) == 0
    assert [r.getMessage() for r in caplog.records if r.levelname == "WARNING"] == [
        f"{tmp_path / 'here.yaml'}: the task did not start: go_to: go to point: the car is already at that point"]
    assert "manual" in lines[-1]


def test_up_closes_its_bus_and_simulator_when_the_loop_fails(monkeypatch):
    closed = []

    class Bus(programs.LocalBus):
        def close(self) -> None:
            closed.append("bus")
            super().close()

    class Sim(programs.Simulator):
        def close(self) -> None:
            closed.append("sim")
            super().close()

    def fail(*_args, **_kwargs) -> None:
        raise RuntimeError("boom")

    monkeypatch.setattr(programs, "LocalBus", Bus)
    monkeypatch.setattr(programs, "Simulator", Sim)
    monkeypatch.setattr(programs, "run_paced", fail)
    with pytest.raises(RuntimeError, match="boom"):
        programs.up(load_scenario(BUNDLED / "course_30kmh_stanley.yaml"), 1.0, 1.0, print)
    assert closed == ["sim", "bus"]  # in the reverse order of opening
