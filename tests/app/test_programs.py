"""``vilma up``: simulator and driver in one process, paced, ended by its duration or a signal."""

from __future__ import annotations

import json
import signal
import subprocess
import sys

import numpy as np
import pytest
from mcap.reader import make_reader

from tests.scenario.test_reactive_traffic import CAR_SPEED, _scenario
from tests.world.test_reactive import _idm_stop
from vilma.app import programs
from vilma.app.batch import BUNDLED
from vilma.record.reader import read_recording
from vilma.scenario import load_scenario
from vilma.scenario.orders import task_order
from vilma.world import reactive
from vilma.world.reactive import IdmParams


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


def test_a_repeated_stop_signal_during_shutdown_does_not_kill_the_program():
    """``timeout`` sends its TERM twice (to the program, then to its group): the second may come after the block,
    while the program closes; it must not kill it. Without a signal, the previous handlers come back."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        with programs.stop_on_signals() as stop:
            signal.raise_signal(signal.SIGTERM)
            assert stop.wait(10)
        signal.raise_signal(signal.SIGTERM)  # the repeat, after the block: this process lives on
        signal.raise_signal(signal.SIGINT)
    finally:
        for s, h in before.items():
            signal.signal(s, h)
    with programs.stop_on_signals() as stop:
        pass
    assert {s: signal.getsignal(s) for s in before} == before and not stop.is_set()


def test_a_closed_terminal_stops_a_program_unless_nohup_ignores_it():
    """SIGHUP (the terminal closed) stops a program as Ctrl-C does, its recording finished; ``nohup``'s ignored
    SIGHUP stays ignored."""
    before = signal.getsignal(signal.SIGHUP)
    try:
        with programs.stop_on_signals() as stop:
            signal.raise_signal(signal.SIGHUP)
            assert stop.wait(10)
        signal.signal(signal.SIGHUP, signal.SIG_IGN)
        with programs.stop_on_signals() as stop:
            signal.raise_signal(signal.SIGHUP)
        assert not stop.is_set() and signal.getsignal(signal.SIGHUP) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, before)


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


def _traffic_and_ego(path, vehicle) -> tuple[np.ndarray, np.ndarray]:
    """The recorded car's x [m] in the ``traffic`` frames of the MCAP file ``path`` (those after sim time 0 that
    show it), and the ego's box centre's x [m] then (its pose at the frame's stamp, heading +x)."""
    with path.open("rb") as f:
        frames = [(m.log_time, json.loads(m.data)) for _, _, m in make_reader(f).iter_messages(
            topics=["vilma/vilma/traffic"])]
    pose = read_recording(path).readings("pose")
    at = dict(zip(pose.stamp_ns.tolist(), pose.values[:, 0].tolist(), strict=True))
    frames = [(t, u) for t, u in frames if t in at and u["entities"]]  # (poses from the first period on)
    car = np.array([u["entities"][0]["cubes"][0]["pose"]["position"]["x"] for _, u in frames])
    return car, np.array([at[t] for t, _ in frames]) + vehicle.body_offset


DURATION = 20.0  # [s]: long enough for the reactive car to close up to the ego


@pytest.mark.slow
def test_up_drives_reactive_traffic_which_brakes_behind_the_slow_ego(tmp_path, monkeypatch):
    """``vilma up --record`` of a faster recorded car behind a slow ego: reactive, the recording shows it brake
    and follow the ego; recorded, it drives through the ego's place. The traffic keeps a ring of 1 s here, so
    that the run laps it (an open-ended run's memory stays bounded) and every reader reads it lapped."""
    monkeypatch.setattr(reactive, "RING", 1.0)
    got = {}
    for mode in ("reactive", "recorded"):
        (tmp_path / mode).mkdir()
        sc = _scenario(tmp_path / mode, f"traffic: {mode}")
        assert programs.up(sc, 50.0, DURATION, lambda _: None, record=tmp_path / f"{mode}.mcap") == 0
        got[mode] = _traffic_and_ego(tmp_path / f"{mode}.mcap", sc.sim.vehicle)
    car_half, ego_half, dt, p = 4.5 / 2, sc.sim.vehicle.length / 2, sc.road.dt, IdmParams()  # a 4.5 m box car
    assert len(got["reactive"][0]) >= round(DURATION / dt) - 1
    car, ego = got["reactive"]
    gap = (ego - ego_half) - (car + car_half)  # bumper to bumper [m]
    # IDM comes closest behind a standing leader (the ego drives on): from the start's gap at its speed, the
    # model's own approach stops at its smallest gap (a little short of s0); the integration at the driver
    # period rather than finely differs by centimetres (tests/world/test_reactive.py)
    _, smallest = _idm_stop(p, gap[0], CAR_SPEED, CAR_SPEED, 0.001)
    assert gap.min() >= smallest - 0.01 and smallest > 0.8 * p.s0
    # then it follows at the ego's speed v at IDM's equilibrium gap (s0 + v T) / sqrt(1 - (v / v0)^delta), its
    # desired speed v0 the recorded one (Treiber et al. 2000)
    v = (ego[-1] - ego[-11]) / (10 * dt)
    assert (car[-1] - car[-11]) / (10 * dt) == pytest.approx(v, abs=0.05)
    assert gap[-1] == pytest.approx((p.s0 + v * p.T) / np.sqrt(1 - (v / CAR_SPEED) ** p.delta), abs=0.05)
    car, ego = got["recorded"]
    assert (car > ego).any() and np.diff(car).mean() / dt == pytest.approx(CAR_SPEED)  # through the ego, as recorded


def test_a_plan_task_is_a_plan_order_to_its_goal_with_the_scenario_planner_and_perception():
    scenario = load_scenario(BUNDLED / "planned_slower_lead.yaml")
    route = scenario.reference_path()
    order = task_order(scenario)
    assert (order.action, order.x, order.y) == ("plan", *route.xy[-1])  # the route ends at the goal
    assert np.array_equal(order.points, route.xy) and np.array_equal(order.speeds, route.speed)
    with programs.LocalBus() as bus, programs.serve_driver(
            programs.Driver(scenario.sim.vehicle, scenario.driver, step=scenario.sim.step), bus, "vilma",
            round(scenario.sim.step * 1e9), scenario) as node:
        setup = node.planning
        assert (setup.params, setup.perception, setup.laser) == (scenario.planner, "laser", scenario.sim.laser)
        assert setup.road is scenario.road.network  # a CommonRoad world: its plans keep within the road's edges


@pytest.mark.slow
def test_up_stops_a_planned_car_behind_the_parked_car():
    """``vilma up`` drives a plan task by its plans, as ``vilma run`` does: with its own lane only to plan in, it
    stops behind the parked car (Werling's d0 = 5 m, less 1 m of speed tracking) instead of following the route
    through it."""
    scenario = load_scenario(BUNDLED / "planned_parked_car.yaml", {"planner.lateral_offsets": "[0]"})
    lines: list[str] = []
    assert programs.up(scenario, 100.0, 20.0, lines.append) == 0
    last = lines[-1].split()
    x, speed = float(last[last.index("x") + 1]), float(last[last.index("speed") + 1])
    assert "plan" in last and speed < scenario.driver.rest_speed
    traffic, car = scenario.sim.traffic, scenario.sim.vehicle
    (where,) = traffic.at(0.0)[0]  # the parked car, as the scenario's file has it, facing +x
    gap = (where[0] + traffic.outline[0, :, 0].min()) - (x + car.body_offset + car.length / 2)
    assert gap >= 4.0
