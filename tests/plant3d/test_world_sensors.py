"""Cameras and the laser in the simulator: captured at their rates where the car is at their stamps, and
published on the bus beside the other sensors."""

from __future__ import annotations

import json
import re
import socket

import numpy as np
import pytest

from tests.bus.test_zenoh import _stop, _wait
from tests.conftest import free_port
from vilma.bus import Latest, LocalBus
from vilma.bus.nodes import SimNode
from vilma.bus.topics import topic
from vilma.bus.zenoh_bus import ZenohBus, ZenohConfig
from vilma.core.messages import ActuatorCommand, Image, PointCloud
from vilma.plant3d.camera import stereo_pair
from vilma.plant3d.laser import LaserParams
from vilma.plant3d.world import Box, World
from vilma.record.reader import read_recording
from vilma.record.run import record_run
from vilma.scenario import load_scenario
from vilma.sim import SimConfig, Simulator
from vilma.vehicle.state import VehicleState

WALL = Box(pos=(25.0, 0.0, 1.0), size=(0.5, 5.0, 1.0), name="wall")
LASER = LaserParams(rate_hz=25.0)  # every 40 ms: at the stamps of the 50 Hz pose


def _config() -> SimConfig:
    return SimConfig(model="mujoco", world=World(boxes=(WALL,)), laser=LASER,
                     cameras=stereo_pair(baseline=0.3, width=160, height=120, rate_hz=10.0, depth=True))


def test_captures_come_at_their_rates_and_see_the_car_where_it_is_at_their_stamp():
    sim = Simulator(_config())
    sim.reset(VehicleState(vx=10.0))
    poses = {}
    scans, images = [], []
    for _ in range(50):  # one second of 20 ms frames, coasting at about 10 m/s
        sim.command(ActuatorCommand(drive=200.0))
        r = sim.advance(2)
        poses.update(zip(r["pose"].stamp_ns.tolist(), r["pose"].field("x").tolist(), strict=True))
        for name, msg in sim.take_captures():
            (scans if name == "laser" else images).append((name, msg))
    sim.close()
    assert [m.stamp_ns for _, m in scans] == [k * 40_000_000 for k in range(1, 26)]
    names = [n for n, _ in images]
    assert names == ["camera/front_left", "camera/front_left/depth", "camera/front_right",
                     "camera/front_right/depth"] * 10
    assert all(m.stamp_ns % 100_000_000 == 0 for _, m in images)
    mid = len(LASER.bearings) // 2  # the ray straight ahead
    for _, scan in scans:
        ahead = np.frombuffer(scan.ranges, dtype="<f4")[mid]
        # the wall's near face, from the laser's mount on the car where the pose sensor put it at that stamp
        expected = WALL.pos[0] - WALL.size[0] - (poses[scan.stamp_ns] + LASER.position[0])
        assert ahead == pytest.approx(expected, abs=0.01)


def test_the_sim_node_publishes_images_and_scans_on_their_topics():
    sim = Simulator(_config())
    bus = LocalBus()
    node = SimNode(sim, bus)
    got: dict[str, list] = {"camera/front_left": [], "camera/front_right/depth": [], "laser": []}
    subs = [bus.subscribe(topic(name), got[name].append) for name in got]
    handed = []
    node.on_captures = handed.extend
    for _ in range(10):
        node.frame(sim.advance(2), 20_000_000)
    assert len(got["camera/front_left"]) == 2 and len(got["laser"]) == 5
    left = got["camera/front_left"][0]
    assert isinstance(left, Image) and (left.width, left.height, left.encoding) == (160, 120, "rgb8")
    assert len(left.data) == left.height * left.step
    depth = got["camera/front_right/depth"][0]
    assert depth.encoding == "32FC1" and len(depth.data) == 160 * 120 * 4
    assert isinstance(got["laser"][0], PointCloud)
    assert len(handed) == 2 * 4 + 5  # the same captures, handed on to the MORSE interface
    for s in subs:
        s.close()
    sim.close()


@pytest.mark.slow
def test_vilma_sim_serves_camera_images_and_scans_over_zenoh(tmp_path, processes):
    scenario = tmp_path / "eyes.yaml"
    scenario.write_text("plant: mujoco\ncameras: {stereo: {width: 160, height: 120, rate_hz: 10}}\nlaser: true\n"
                        "task: {speed: 3}\n", encoding="utf-8")
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    sim = processes.vilma("sim", str(scenario), "--speed", "2", "--listen", endpoint, "--no-morse")
    watcher = ZenohBus(ZenohConfig(listen=("tcp/127.0.0.1:0",), connect=(endpoint,)))
    right, scan = Latest(watcher, topic("camera/front_right")), Latest(watcher, topic("laser"))
    try:
        _wait(lambda: right.value is not None and scan.value is not None, 120, "an image and a scan")
        assert (right.value.width, right.value.height, len(right.value.data)) == (160, 120, 160 * 120 * 3)
        assert right.value.frame_id == "front_right"
        assert len(scan.value.ranges) == 4 * len(LaserParams().bearings)
    finally:
        watcher.close()
        _stop(sim)


@pytest.mark.slow
def test_a_run_records_its_camera_images_and_scans(tmp_path):
    scenario = tmp_path / "rec.yaml"
    scenario.write_text("plant: mujoco\ncameras: [{name: dash, width: 64, height: 48, rate_hz: 10}]\n"
                        "laser: {rate_hz: 5}\ntask: {speed: 3}\nduration: 2\n", encoding="utf-8")
    record_run(load_scenario(scenario), tmp_path / "out")
    rec = read_recording(tmp_path / "out" / "run.mcap")
    images = rec.messages("camera/dash")
    assert len(images) == 20 and {(i.width, i.height) for i in images} == {(64, 48)}  # 2 s at 10 Hz
    assert [s.stamp_ns for s in rec.messages("laser")] == [k * 200_000_000 for k in range(1, 11)]


def test_vilma_sim_streams_the_laser_to_morse_clients(tmp_path, processes):
    scenario = tmp_path / "laser.yaml"
    scenario.write_text("plant: mujoco\nlaser: {max_range: 20}\ntask: {speed: 0.0001}\n", encoding="utf-8")
    sim = processes.vilma("sim", str(scenario), "--listen", "tcp/127.0.0.1:0", "--morse-port", "0",
                          "--morse-stream-port", "0")
    try:
        port = _morse_port(sim)
        with socket.create_connection(("127.0.0.1", port)) as c:
            c.sendall(b'1 simulation get_stream_port ["vilma.laser"]\n')
            stream = int(c.makefile("rb").readline().split()[2])
        with socket.create_connection(("127.0.0.1", stream)) as s:
            scan = json.loads(s.makefile("rb").readline())
        assert len(scan["range_list"]) == len(LaserParams().bearings)
        assert set(scan["range_list"]) == {20.0}  # nothing around the car: every ray at the laser's range
    finally:
        _stop(sim)


def _morse_port(sim) -> int:
    """The MORSE service port the program's banner names (it listens before it says so)."""
    for line in sim.stdout:
        if m := re.search(r"MORSE services on 127\.0\.0\.1:(\d+)", line):
            return int(m.group(1))
    raise AssertionError("vilma sim ended without serving MORSE")
