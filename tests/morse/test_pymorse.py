"""pymorse 1.4, MORSE's own Python client, against vilma's MORSE interface."""

from __future__ import annotations

import math
import threading

import numpy as np
import pymorse
import pytest

from tests.morse.conftest import IMU_AT, START, LineClient, serve
from tests.record.world_messages import WALL, wall_rays, wall_scan
from vilma.morse import COMPONENTS


@pytest.fixture
def fixed_close(monkeypatch):
    """pymorse's Morse.close() always raises on Python 3 (reference/morse-protocol.md 9.2): the client-side fix."""

    def getattribute(self, name):
        v = object.__getattribute__(self, name)
        if not isinstance(v, type) and hasattr(v, "lazy_init"):
            v.lazy_init()
        return v

    monkeypatch.setattr(pymorse.pymorse.Component, "__getattribute__", getattribute)


@pytest.fixture
def sim(served, fixed_close):
    with pymorse.Morse("127.0.0.1", served.port) as m:
        yield m


def test_discovery_builds_the_robot_and_its_components(sim, served):
    assert sim.robots == ["vilma"]
    for name in ("pose", "velocity", "gps", "imu", "wheelspeed", "odometry", "steer_force", "motion"):
        assert hasattr(sim.vilma, name)
    assert sim.streams() == list(served.server.stream_ports)
    assert sim.get_stream_port("vilma.gps") == served.server.stream_ports["vilma.gps"]


def test_streams_get_last_and_subscribe(sim):
    first = sim.vilma.pose.get(timeout=5)
    second = sim.vilma.pose.get(timeout=5)
    assert second["timestamp"] > first["timestamp"]
    assert sim.vilma.pose.last()["timestamp"] >= second["timestamp"]
    got = threading.Event()
    frames = []

    def on_wheels(data):
        frames.append(data)
        got.set()

    sim.vilma.wheelspeed.subscribe(on_wheels)
    assert got.wait(5)
    sim.vilma.wheelspeed.unsubscribe(on_wheels)
    assert set(frames[0]) == {"timestamp", "w_fl", "w_fr", "w_rl", "w_rr"}


@pytest.fixture
def real_time_sim(fixed_close):
    """pymorse on a simulator paced at real time, as MORSE runs: the client's commands follow its ``sleep``
    replies over the socket, and every wall second they lag costs a sim second, not four."""
    s = serve(speed=1.0)
    try:
        with pymorse.Morse("127.0.0.1", s.port) as m:
            yield m
    finally:
        s.stop.set()
        s.server.stop()


@pytest.mark.slow
def test_steer_force_follows_morses_reference_drive(real_time_sim):
    """MORSE's testing/base/steer_force_testing.py: force -20 for 3 s then brake 10 for 1 s moves the car about
    8.5 m forward (+-1); force -40 for 3 s then brake for 2 s, about 28 m in total."""
    sim = real_time_sim
    x0 = sim.vilma.pose.get()["x"]
    sim.vilma.steer_force.publish({"steer": 0.0, "force": -20.0, "brake": 0.0})
    sim.sleep(3.0)
    sim.vilma.steer_force.publish({"steer": 0.0, "force": 0.0, "brake": 10.0})
    sim.sleep(1.0)
    assert sim.vilma.pose.get()["x"] - x0 == pytest.approx(8.5, abs=1.0)
    sim.vilma.steer_force.publish({"steer": 0.0, "force": -40.0, "brake": 0.0})
    sim.sleep(3.0)
    sim.vilma.steer_force.publish({"steer": 0.0, "force": 0.0, "brake": 10.0})
    sim.sleep(2.0)
    assert sim.vilma.pose.get()["x"] - x0 == pytest.approx(28.0, abs=1.0)


def test_services_futures_time_and_errors(sim, served):
    sim.sleep(0.1)  # at sim time 0 exactly, "time now" is falsy and MORSE sends no payload (pymorse: None)
    t = sim.time()
    sim.sleep(0.5)
    assert sim.time() - t >= 0.5
    future = sim.vilma.pose.get_local_data()
    assert set(future.result()) == {"timestamp", "x", "y", "z", "yaw", "pitch", "roll"}
    assert sim.rpc("vilma", "steer", 1, 0.2) is None
    assert served.commands[-1].steer == 0.2
    assert sim.vilma.status().result() is None  # a speed of 0 is falsy: MORSE sends a bare SUCCESS
    sim.rpc("vilma", "controlpower", 1, 1000, 3.0)
    sim.sleep(3.0)
    assert sim.vilma.status().result() == pytest.approx(served.sim.state.speed, abs=0.2)
    with pytest.raises(TypeError, match="wrong # of parameters"):
        sim.rpc("vilma", "steer", 1)
    with pytest.raises(pymorse.MorseServiceFailed, match="has not been registered"):
        sim.rpc("vilma", "fly")
    with pytest.raises(pymorse.MorseServiceFailed, match="must be a finite number"):
        sim.rpc("vilma", "steer", 1, float("nan"))


def test_a_second_sleep_fails_while_one_runs(sim, served):
    raw = LineClient(served.port)
    assert raw.ask(b"long time sleep [1000.0]\nfence time mode\n").startswith(b"fence SUCCESS")
    with pytest.raises(pymorse.MorseServiceFailed, match=r"^A service \(sleep\) is already running\. I do not know"):
        sim.sleep(0.1)
    raw.send(b"long cancel\n")
    assert raw.line() == b"long PREEMPTED\n"  # the first sleep was still running
    assert sim.sleep(0.1) is None
    raw.close()


def test_time_statistics(sim):
    sim.sleep(0.1)  # five frames of 20 ms
    stats = sim.rpc("time", "statistics")
    assert set(stats) == {"mean_time", "variance_time", "diff_real_time"}  # MORSE's fixed-step figures
    assert stats["mean_time"] > 0 and stats["variance_time"] >= 0


def test_reset_then_quit_ends_the_simulator(scene, fixed_close):
    start = pytest.approx((START.x, START.y, START.yaw), abs=1e-9)
    with pymorse.Morse("127.0.0.1", scene.port) as m:
        m.vilma.steer_force.publish({"steer": 0.0, "force": -20.0, "brake": 0.0})
        m.sleep(2.0)
        moved = m.vilma.pose.get()
        assert math.hypot(moved["x"] - START.x, moved["y"] - START.y) > 1.0
        m.vilma.steer_force.publish({"steer": 0.0, "force": 0.0, "brake": 0.0})
        assert m.reset() == "Objects restored to initial position"
        local = m.vilma.pose.get_local_data().result()
        assert (local["x"], local["y"], local["yaw"]) == start
        streamed = m.vilma.pose.get(timeout=5)
        assert (streamed["x"], streamed["y"], streamed["yaw"]) == start
        m.quit()
    assert scene.stop.wait(2.0)


def test_component_services_and_scene_objects(scene, fixed_close):
    with pymorse.Morse("127.0.0.1", scene.port) as m:
        assert m.vilma.pose.get_properties().result() == {"properties": {}}
        assert m.vilma.imu.get_properties().result()["properties"]["ComputationMode"][0] == "Velocity"
        placed = m.vilma.imu.get_configurations().result()["configurations"]["object_to_robot"]
        assert placed == {"rotation": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "translation": list(IMU_AT)}
        m.vilma.pose.get(timeout=5)  # a pose has been measured
        children, position, quaternion = m.rpc("simulation", "get_scene_objects")["vilma"]
        assert position == pytest.approx([START.x, START.y, 0.0], abs=1e-9)
        assert quaternion == pytest.approx([0.0, 0.0, math.sin(START.yaw / 2), math.cos(START.yaw / 2)], abs=1e-9)
        assert set(children) == {f"vilma.{c.name}" for c in COMPONENTS}
        m.quit()


def test_pymorse_reads_the_laser_stream(fixed_close):
    # before test_a_second_server_for_a_second_client: its unfixed close() leaves a pymorse poll thread behind
    s = serve(world_topics=("laser",), laser_range=25.0)
    stop = threading.Event()

    def scans() -> None:  # pymorse's get() waits for the next line: keep scanning, at 20 Hz of wall time
        k = 0
        while not stop.wait(0.05):
            k += 1
            s.server.publish_captures({"laser": wall_scan(stamp_ns=k * 50_000_000)})

    feeder = threading.Thread(target=scans, daemon=True)
    feeder.start()
    try:
        with pymorse.Morse("127.0.0.1", s.port) as m:
            assert "vilma.laser" in m.streams()
            scan = m.vilma.laser.get(timeout=5)
            later = m.vilma.laser.get(timeout=5)
            assert later["timestamp"] > scan["timestamp"] > 0
            angles, ranges = wall_rays()
            hit = np.isfinite(ranges)
            points = np.array(scan["point_list"])
            assert points.shape == (len(angles), 3)
            assert np.allclose(points[hit, 0], WALL, atol=1e-5)
            assert np.allclose(points[hit, 1], WALL * np.tan(angles[hit]), atol=1e-5)
            assert np.all(points[~hit] == 0) and set(np.array(scan["range_list"])[~hit]) == {25.0}
            assert m.vilma.laser.get_local_data().result()["timestamp"] >= later["timestamp"]
            m.quit()
    finally:
        stop.set()
        feeder.join(2)
        s.stop.set()
        s.server.stop()


def test_a_second_server_for_a_second_client():
    s = serve()
    try:
        with pymorse.Morse("127.0.0.1", s.port) as m:
            assert m.robots == ["vilma"]
            m.quit()
    except TypeError:  # close() without the client-side fix raises, as with real MORSE (protocol 9.2)
        pass
    finally:
        s.stop.set()
        s.server.stop()

