"""``vilma gui`` from the command line, and joining a simulator over Zenoh that goes away and comes back."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import time

import pytest

from tests.conftest import Processes, free_port
from tests.gui.conftest import WAIT_MS
from vilma.bus import Latest, topic
from vilma.bus.zenoh_bus import ZenohBus, ZenohConfig
from vilma.core.messages import DriverOrder
from vilma.gui.backend import Remote
from vilma.gui.main_window import MainWindow
from vilma.scenario import load_scenario
from vilma.scenario.bundled import find_scenario
from vilma.scenario.orders import task_order


@pytest.mark.slow
def test_vilma_gui_runs_embedded_and_quits_cleanly():
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen"}
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "gui", "--speed", "2", "--quit-after", "2"],
                       capture_output=True, text=True, timeout=120, env=env)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr


def test_vilma_gui_refuses_bad_options_without_a_traceback():
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen"}
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "gui", "--speed", "-1"], capture_output=True, text=True,
                       timeout=60, env=env)
    assert r.returncode == 2 and "--speed" in r.stderr and "Traceback" not in r.stderr
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "gui", "no_such_scenario"], capture_output=True,
                       text=True, timeout=60, env=env)
    assert r.returncode == 2 and "no_such_scenario" in r.stderr and "Traceback" not in r.stderr


def _sim(processes: Processes, endpoint: str) -> subprocess.Popen:
    return processes.vilma("sim", "--listen", endpoint, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _stop(p: subprocess.Popen) -> None:
    p.terminate()
    p.communicate(timeout=WAIT_MS / 1000)


@pytest.mark.slow
def test_connect_shows_a_lost_simulator_and_reconnects_by_itself(qtbot, processes):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sim = _sim(processes, endpoint)
    backend = Remote(ZenohBus(ZenohConfig(listen=("tcp/127.0.0.1:0",), connect=(endpoint,))), endpoint)
    w = MainWindow(backend, refresh_ms=100)
    qtbot.addWidget(w)
    w.show()
    try:
        qtbot.waitUntil(lambda: w.link.text() == "connected", timeout=WAIT_MS)
        _stop(sim)
        qtbot.waitUntil(lambda: w.link.text().startswith("DISCONNECTED"), timeout=WAIT_MS)
        _sim(processes, endpoint)
        qtbot.waitUntil(lambda: w.link.text() == "connected", timeout=WAIT_MS)
        assert "pose" in w.bridge.latest
    finally:
        w.close()
        backend.close()


@pytest.mark.slow
def test_connected_gains_and_table_speeds_reach_a_driver_in_another_process(processes):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    _sim(processes, endpoint)
    processes.vilma("drive", "--connect", endpoint, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    backend = Remote(ZenohBus(ZenohConfig(listen=("tcp/127.0.0.1:0",), connect=(endpoint,))), endpoint)
    try:
        order = topic("driver/cmd")
        deadline = time.monotonic() + WAIT_MS / 1000
        while not backend.bus.request(order, DriverOrder(action="manual"), timeout=0.5).ok:
            assert time.monotonic() < deadline, "the driver never answered"
        tuned = dataclasses.replace(backend.driver_params, path_controller="stanley").with_gains(
            {"stanley": dataclasses.replace(backend.driver_params.gains_of("stanley"), gain=1.7)})
        backend.set_driver_params(tuned)
        assert backend.driver_params.gains_of("stanley").gain == 1.7
        bad = dataclasses.replace(tuned, speed_controller="pi_ff").with_gains(
            {"pi_ff": dataclasses.replace(tuned.gains_of("pi_ff"), period=0.013)})
        with pytest.raises(ValueError, match="tune: "):
            backend.set_driver_params(bad)
        assert backend.driver_params == tuned  # what was refused is not taken
        reply = backend.bus.request(order, DriverOrder(action="follow", points=[(0.0, 0.0), (30.0, 0.0)],
                                                       speeds=[3.0, 3.0]))
        assert reply.ok, reply.error
        status = Latest(backend.bus, topic("driver/status"))
        deadline = time.monotonic() + WAIT_MS / 1000
        while not (status.value is not None and status.value.mode == "follow" and status.value.target_speed == 3.0):
            assert time.monotonic() < deadline, f"no follow at the table's speed: {status.value}"
            time.sleep(0.05)
    finally:
        backend.close()


@pytest.mark.slow
def test_plan_on_a_gui_joined_over_zenoh_orders_the_scenarios_plan_task(qtbot, processes):
    """The GUI started with the scenario of ``vilma sim`` sends its plan task to ``vilma drive`` (the same order
    ``vilma up`` sends), which plans it."""
    sc = load_scenario(find_scenario("planned_parked_car"))
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    processes.vilma("sim", "planned_parked_car", "--listen", endpoint, stdout=subprocess.DEVNULL,
                    stderr=subprocess.PIPE)
    processes.vilma("drive", "--connect", endpoint, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    backend = Remote(ZenohBus(ZenohConfig(listen=("tcp/127.0.0.1:0",), connect=(endpoint,))), endpoint, scenario=sc)
    orders = Latest(backend.bus, topic("driver/cmd"))
    w = MainWindow(backend, refresh_ms=100)
    qtbot.addWidget(w)
    w.show()
    try:
        qtbot.waitUntil(lambda: w.link.text() == "connected" and "driver/status" in w.bridge.latest, timeout=WAIT_MS)
        assert w.auto_dock.plan_button.isEnabled()
        w.auto_dock.plan_button.click()
        qtbot.waitUntil(lambda: w.bridge.latest["driver/status"].mode == "plan", timeout=WAIT_MS)
        qtbot.waitUntil(lambda: orders.value is not None, timeout=WAIT_MS)  # the order taken, as the driver publishes
        want = task_order(sc)
        assert (orders.value.action, orders.value.x, orders.value.y) == (want.action, want.x, want.y)
        qtbot.waitUntil(lambda: "planning/plan" in w.bridge.latest, timeout=WAIT_MS)  # it plans
        assert w.auto_dock.plan_button.isChecked()
    finally:
        orders.close()
        w.close()
        backend.close()
