"""Real Zenoh sessions between real processes: vilma sim and vilma drive on loopback."""

from __future__ import annotations

import logging
import math
import signal
import subprocess
import sys
import threading
import time

import pytest
import zenoh

from tests.bus.conftest import data_folder
from tests.conftest import free_port
from vilma.app.batch import BUNDLED
from vilma.bus import Latest, topic
from vilma.bus.codec import MAX_FRAME_BYTES, decode, encode
from vilma.bus.zenoh_bus import MAX_MESSAGE_BYTES, ZenohBus, ZenohConfig
from vilma.core.messages import MAX_ORDER_POINTS, DriverOrder, Pose, Reply, SimControl
from vilma.scenario import load_scenario
from vilma.scenario.runner import run

SPEED = 4.0
"""The simulator runs at this many times real time in these tests."""


def _wait(predicate, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)


def _stop(proc: subprocess.Popen) -> None:
    """SIGINT: it must exit cleanly (how fast is a benchmark's business, not a test's)."""
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode == 0, out


@pytest.fixture
def sim_endpoint(processes):
    run(load_scenario(BUNDLED / "course_30kmh_stanley.yaml"), compiled=False)  # fill the compiled-code cache first
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sim = processes.vilma("sim", "course_30kmh_stanley", "--speed", str(SPEED), "--listen", endpoint, "--no-morse")
    watcher = ZenohBus(ZenohConfig(listen=("tcp/127.0.0.1:0",), connect=(endpoint,)))
    pose = Latest(watcher, topic("pose"))
    _wait(lambda: pose.value is not None, 120, "the simulator's first pose")
    yield endpoint, watcher
    watcher.close()
    _stop(sim)


@pytest.mark.slow
def test_sim_and_drive_in_two_processes_follow_the_course_to_its_end(sim_endpoint, processes):
    endpoint, watcher = sim_endpoint
    status = Latest(watcher, topic("driver/status"))
    drive = processes.vilma("drive", "course_30kmh_stanley", "--connect", endpoint)
    _wait(lambda: status.value is not None and status.value.arrived, 180, "the car to arrive")
    end = load_scenario(BUNDLED / "course_30kmh_stanley.yaml").reference_path().xy[-1]
    _wait(lambda: watcher_speed(watcher) < 0.05, 10, "the car to stop")
    p = Latest(watcher, topic("pose"))
    _wait(lambda: p.value is not None, 5, "a pose")
    assert math.hypot(p.value.x - end[0], p.value.y - end[1]) < 1.0
    _stop(drive)


def watcher_speed(bus: ZenohBus) -> float:
    v = Latest(bus, topic("velocity"))
    _wait(lambda: v.value is not None, 5, "a velocity")
    v.close()
    return v.value.speed


@pytest.mark.slow
def test_killed_driver_the_watchdog_stops_the_car_and_a_new_driver_resumes(sim_endpoint, processes):
    endpoint, watcher = sim_endpoint
    poses, speeds, trips, commands = [], [], [], []
    watcher.subscribe(topic("cmd"), commands.append)
    watcher.subscribe(topic("pose"), poses.append)
    watcher.subscribe(topic("velocity"), speeds.append)
    watcher.subscribe(topic("sim/status"), lambda st: trips.append(st) if st.watchdog_tripped else None)
    drive = processes.vilma("drive", "course_30kmh_stanley", "--connect", endpoint)
    _wait(lambda: speeds and speeds[-1].speed > 7.0, 120, "cruising speed")
    drive.kill()
    drive.communicate()
    _wait(lambda: trips and speeds[-1].speed < 0.05, 60, "the watchdog to stop the car")
    # From the frame the watchdog tripped in (sim time: how long the kill takes to cross the bus plays no part),
    # the car brakes at 3 m/s^2 through the brake's first-order lag: at most v tau + v^2 / (2 a) to rest.
    trip = trips[0].stamp_ns
    assert trip >= commands[-1].stamp_ns + 500_000_000  # never before its 0.5 s after the last command
    v = max(m.speed for m in speeds if trip - 20_000_000 <= m.stamp_ns <= trip)  # the frame's velocity samples
    at, rest = next(p for p in poses if p.stamp_ns >= trip), poses[-1]
    actuators = load_scenario(BUNDLED / "course_30kmh_stanley.yaml").sim.vehicle.actuators
    assert math.hypot(rest.x - at.x, rest.y - at.y) < v * actuators.brake_time_constant + \
        v * v / (2 * actuators.stop_deceleration)
    status = Latest(watcher, topic("driver/status"))
    again = processes.vilma("drive", "course_30kmh_stanley", "--connect", endpoint)
    _wait(lambda: status.value is not None and status.value.arrived, 180, "the new driver to finish the course")
    _stop(again)


def test_a_malformed_frame_is_dropped_with_a_warning_and_the_next_is_read(caplog):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    a = ZenohBus(ZenohConfig(listen=(endpoint,)))
    b = ZenohBus(ZenohConfig(connect=(endpoint,)))
    got, ready = [], threading.Event()
    b.subscribe(topic("pose"), lambda m: (got.append(m), ready.set()))
    raw = a.session.declare_publisher(topic("pose"), congestion_control=zenoh.CongestionControl.BLOCK)
    good = Pose(1, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0)
    warning = "dropped a message on vilma/vilma/pose: not a vilma frame"
    with caplog.at_level(logging.WARNING):
        deadline = time.monotonic() + 10
        # until the peers have met and both frames arrived (two publishers: either may arrive first)
        while not (ready.is_set() and warning in caplog.text) and time.monotonic() < deadline:
            raw.put(b"\xc1not msgpack")
            a.publish(topic("pose"), good)
            ready.wait(0.1)
            time.sleep(0.05)
    assert got and all(m == good for m in got)  # the malformed frames never reached the subscriber
    assert warning in caplog.text
    raw.undeclare()
    a.close()
    b.close()


def test_a_peer_flooding_malformed_frames_gets_a_warning_a_second_not_one_each(caplog):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    a = ZenohBus(ZenohConfig(listen=(endpoint,)))
    b = ZenohBus(ZenohConfig(connect=(endpoint,)))
    stamps, done = [], threading.Event()
    b.subscribe(topic("pose"), lambda m: (stamps.append(m.stamp_ns), m.stamp_ns == 2 and done.set()))
    raw = a.session.declare_publisher(topic("pose"), congestion_control=zenoh.CongestionControl.BLOCK)
    _wait(lambda: raw.put(encode(Pose(1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))) or stamps, 10, "the peers to meet")
    flood = 2000
    with caplog.at_level(logging.WARNING, logger="vilma.bus.zenoh_bus"):
        t0 = time.monotonic()
        for _ in range(flood):
            raw.put(b"\xc1not msgpack")
        raw.put(encode(Pose(2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))  # one publisher: it comes after the flood
        assert done.wait(60), "the frame after the flood did not come"
        elapsed = time.monotonic() - t0
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("dropped a message on")]
    assert 1 <= len(lines) <= 1 + elapsed  # one line a second at most (the throttle's period)
    held = sum(int(line.rsplit("(", 1)[1].split()[0]) for line in lines[1:])
    assert len(lines) + held <= flood  # the lines after the first count the frames held back
    raw.undeclare()
    a.close()
    b.close()


def test_a_frame_nested_past_the_recursion_limit_is_dropped_or_answered_with_the_usual_line(caplog):
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    a = ZenohBus(ZenohConfig(listen=(endpoint,)))
    b = ZenohBus(ZenohConfig(connect=(endpoint,)))
    stamps, done = [], threading.Event()
    b.subscribe(topic("pose"), lambda m: (stamps.append(m.stamp_ns), m.stamp_ns == 2 and done.set()))
    b.serve(topic("sim/cmd"), lambda order: Reply(ok=True))
    raw = a.session.declare_publisher(topic("pose"), congestion_control=zenoh.CongestionControl.BLOCK)
    _wait(lambda: raw.put(encode(Pose(1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))) or stamps, 10, "the peers to meet")
    deep = b"\x92\x02" + b"\x91" * 100_000
    with caplog.at_level(logging.WARNING):
        raw.put(deep)
        raw.put(encode(Pose(2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))  # one publisher: it comes after the deep frame
        assert done.wait(10), "the frame after the deep one did not come"
        assert a.request(topic("sim/cmd"), SimControl(action="status")).ok  # known: a raw query reaches it
        replies = [decode(r.ok.payload.to_bytes(), Reply) for r in a.session.get(topic("sim/cmd"), payload=deep,
                                                                                  timeout=5)]
    assert [r.error.split(": ", 2)[:2] for r in replies] == [["vilma/vilma/sim/cmd", "not a vilma frame"]]
    assert "dropped a message on vilma/vilma/pose: not a vilma frame" in caplog.text
    assert not [r for r in caplog.records if r.levelno > logging.WARNING]  # no traceback in any callback
    raw.undeclare()
    a.close()
    b.close()


def test_a_request_sent_as_a_bus_opens_waits_for_the_server_a_peer_tells_of():
    """The server is a peer of the peer connected to (as a driver is of the simulator): it becomes known a moment
    after the bus opens, and a request sent at once must wait for it rather than reach nobody."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    hub = ZenohBus(ZenohConfig(listen=(endpoint,)))
    server = ZenohBus(ZenohConfig(listen=("tcp/127.0.0.1:0",), connect=(endpoint,)))
    server.serve(topic("driver/cmd"), lambda order: Reply(ok=True))
    for _ in range(10):
        with ZenohBus(ZenohConfig(connect=(endpoint,))) as client:
            assert client.request(topic("driver/cmd"), DriverOrder(action="manual"), timeout=10).ok
    server.close()
    hub.close()


def test_a_request_nobody_answers_waits_its_timeout_only_when_it_did():
    with ZenohBus(ZenohConfig()) as bus:
        t0 = time.monotonic()
        reply = bus.request(topic("driver/cmd"), DriverOrder(action="manual"), timeout=0.3)
        assert time.monotonic() - t0 >= 0.3
        assert reply == Reply(ok=False, error="nobody answered on vilma/vilma/driver/cmd within 0.3 s (is the program "
                                              "running?)")
        bus.session.declare_queryable(topic("driver/cmd"), lambda query: None)  # drops each query unanswered
        assert bus.request(topic("driver/cmd"), DriverOrder(action="manual"), timeout=60).error == \
            "the server of vilma/vilma/driver/cmd ended the request without an answer"


def test_endpoints_beyond_loopback_are_recognised():
    """(The warning itself is checked on a real non-loopback listener in test_netns.py.)"""
    cfg = ZenohConfig(listen=("tcp/127.0.0.1:7447", "tcp/localhost:7448", "tcp/[::1]:7449", "tcp/0.0.0.0:7450",
                              "udp/10.0.0.5:7451"))
    assert cfg.exposed() == ["tcp/0.0.0.0:7450", "udp/10.0.0.5:7451"]


def test_a_zenoh_config_refuses_an_endpoint_zenoh_would_not_take_or_never_reach():
    with pytest.raises(ValueError, match=r"^connect endpoint 2: the port must be a whole number 1-65535$"):
        ZenohConfig(connect=("tcp/127.0.0.1:7447", "tcp/127.0.0.1:abc"))
    with pytest.raises(ValueError, match=r"^listen endpoint 1: not an endpoint: give <protocol>/<address>"):
        ZenohConfig(listen=("garbage",))


def test_a_session_zenoh_cannot_open_is_one_line_without_zenohs_source_places():
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with ZenohBus(ZenohConfig(listen=(endpoint,))), pytest.raises(OSError) as e:
        ZenohBus(ZenohConfig(listen=(endpoint,)))
    assert str(e.value).startswith(f"cannot open Zenoh on listen ['{endpoint}'] connect []: ")
    assert "Address already in use" in str(e.value) and ".rs:" not in str(e.value) and "\n" not in str(e.value)


@pytest.mark.slow
def test_zenoh_config_file_and_its_errors(tmp_path):
    good = tmp_path / "z.yaml"
    good.write_text("listen: [tcp/127.0.0.1:0]\nconnect: []\nextra: [[transport/unicast/max_links, '2']]\n")
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "sim", "--zenoh-config", str(good), "--duration", "0.1",
                        "--no-morse"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert "Zenoh listens on tcp/127.0.0.1:0" in r.stdout
    bad = tmp_path / "bad.yaml"
    bad.write_text("listen: tcp/127.0.0.1:0\n")
    r = subprocess.run([sys.executable, "-m", "vilma.app.cli", "sim", "--zenoh-config", str(bad)], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert f"{bad}:1: listen: expected a list" in r.stderr


@pytest.fixture
def drive_with_data(tmp_path, processes):
    """``vilma drive --data-dir`` (a :func:`data_folder`) connected to a Zenoh session of the test's; yields the
    session and the process."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bus = ZenohBus(ZenohConfig(listen=(endpoint,)))
    drive = processes.vilma("drive", "--connect", endpoint, "--data-dir", str(data_folder(tmp_path)))
    deadline = time.monotonic() + 120
    while not bus.request(topic("driver/cmd"), DriverOrder(action="manual"), timeout=0.5).ok:
        assert time.monotonic() < deadline and drive.poll() is None, "the driver never answered"
    yield bus, drive
    bus.close()


def _ask(bus: ZenohBus, payload: bytes) -> list[Reply]:
    """The replies to a raw request on driver/cmd (none if it was dropped)."""
    return [decode(r.ok.payload.to_bytes(), Reply) for r in bus.session.get(topic("driver/cmd"), payload=payload,
                                                                            timeout=5) if r.ok is not None]


@pytest.mark.slow
def test_a_driver_process_refuses_hostile_orders_unread_and_keeps_serving(drive_with_data):
    bus, drive = drive_with_data
    key = topic("driver/cmd")
    for name in ("/etc/passwd", "/dev/zero", "zero", "../secret.txt"):
        assert bus.request(key, DriverOrder(action="follow", file=name, speed=3.0)).error == \
            f"follow: file {name!r} is not in the driver's data folder; name a file in it (no leading '/', no '..', " \
            "no link out of it)"
    bad = bus.request(key, DriverOrder(action="follow", file="bad.txt", speed=3.0))
    assert bad.error == "follow: file 'bad.txt' line 2: not a trajectory file (the driver's log says why)"
    assert bus.request(key, DriverOrder(action="follow", file="good.csv")).ok
    too_many = bus.request(key, DriverOrder(action="follow", points=[(0.0, 0.0)] * (MAX_ORDER_POINTS + 1)))
    assert too_many.error == f"{key}: malformed message: Expected `array` of length <= {MAX_ORDER_POINTS} - at `points`"
    over = MAX_FRAME_BYTES + 1
    assert [r.error for r in _ask(bus, b"\xc1" * over)] == \
        [f"{key}: a frame of {over} bytes, over the 4 MiB limit of DriverOrder; send less in one message"]
    assert _ask(bus, bytes(MAX_MESSAGE_BYTES + 1)) == []  # Zenoh drops it before it reaches vilma
    assert bus.request(key, DriverOrder(action="set_speed", speed=2.0)).ok
    _stop(drive)  # and it stops cleanly


def test_a_zenoh_bus_in_a_with_block_closes_its_session_even_when_the_block_raises():
    with pytest.raises(RuntimeError, match="boom"), ZenohBus(ZenohConfig()) as bus:
        assert isinstance(bus, ZenohBus) and not bus.session.is_closed()
        raise RuntimeError("boom")
    assert bus.session.is_closed()
    bus.close()  # a second close does nothing
