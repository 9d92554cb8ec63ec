"""``vilma ros1-bridge`` on a real ROS 1 master: a rospy node (ros1_probe.py) gets the car's pose and drives it
through /cmd; the watchdog stops the car when the node stops; bad messages on /cmd are warned about, a line a
second at most; SIGINT stops the bridge cleanly.

Skipped where ROS 1 is not installed (Debian: ros-core python3-rospy python3-geometry-msgs python3-sensor-msgs
python3-std-msgs); .ci/run installs it and sets VILMA_REQUIRE_ROS1=1, which makes a missing ROS 1 a failure.
"""

from __future__ import annotations

import io
import json
import math
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.conftest import free_port
from vilma.app.options import scenario_or_default
from vilma.record.ros1 import CommandMessageError, command_numbers, rospy_or_reason

rospy, WHY = rospy_or_reason()  # every ROS module the bridge and the probe import; the probe runs in its own process
MISSING = WHY if rospy is None else "" if shutil.which("roscore") else \
    "ROS 1 is not installed: no roscore on PATH (apt-get install ros-core)"
"""Why these tests cannot run here ("" if they can)."""

PROBE = Path(__file__).with_name("ros1_probe.py")


@pytest.fixture(scope="module", autouse=True)
def ros1_installed():
    """Skip where ROS 1 is missing; fail instead where it must be there (VILMA_REQUIRE_ROS1=1: CI installed it)."""
    if MISSING and os.environ.get("VILMA_REQUIRE_ROS1") == "1":
        pytest.fail(f"VILMA_REQUIRE_ROS1=1 but {MISSING}", pytrace=False)
    if MISSING:
        pytest.skip(MISSING)


def _ros_env(folder: Path, port: int) -> dict[str, str]:
    return {**os.environ, "ROS_MASTER_URI": f"http://127.0.0.1:{port}", "ROS_IP": "127.0.0.1",
            "ROS_HOSTNAME": "127.0.0.1", "ROS_HOME": str(folder / "ros"), "ROS_LOG_DIR": str(folder / "log")}


@pytest.fixture(scope="module")
def ros_env(tmp_path_factory):
    port = free_port()
    env = _ros_env(tmp_path_factory.mktemp("ros"), port)
    core = subprocess.Popen(["roscore", "-p", str(port)], env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    try:
        for line in core.stdout:  # roscore says when its master runs
            if "started core service" in line:
                break
        else:
            pytest.fail("roscore ended before its master started")
        yield env
    finally:
        core.terminate()  # roscore ends its master and rosout (a kill would leave them)
        core.communicate(timeout=60)


@pytest.fixture
def bridge(ros_env, tmp_path, processes):
    """A running ``vilma ros1-bridge`` (the defaults' car at real time), its stderr going to ``bridge.err`` in
    ``tmp_path``; the test stops it with :func:`_sigint`."""
    with open(tmp_path / "bridge.err", "w") as err:
        p = processes.vilma("ros1-bridge", "--speed", "1", env=ros_env, stderr=err)
    assert p.stdout.readline().startswith("vilma ros1-bridge:")  # the banner: its node is up
    return p


def _probe(env: dict[str, str], *args: str) -> list[dict]:
    out = subprocess.run([sys.executable, str(PROBE), *args], env=env, capture_output=True, text=True, timeout=180)
    assert out.returncode == 0, out.stderr
    return [json.loads(line) for line in out.stdout.splitlines()]


def _sigint(p: subprocess.Popen, err: Path) -> str:
    """SIGINT, then the program's stderr (in ``err``) once it ended, cleanly (as vilma's other programs: exit 0)."""
    p.send_signal(signal.SIGINT)
    p.communicate(timeout=60)
    text = err.read_text()
    assert p.returncode == 0 and "Traceback" not in text, text
    return text


@pytest.mark.slow
def test_a_ros_command_moves_the_car_and_the_watchdog_stops_it_when_the_publisher_stops(ros_env, bridge, tmp_path):
    force = 3000.0  # forward drive force [N], wheels straight: as [steer, drive, brake], the 3-number form
    first, moved, stopped, rest = _probe(ros_env, "drive", str(force))
    _sigint(bridge, tmp_path / "bridge.err")
    assert first["frame"] == "/map"
    assert first["stamp_ns"] % 20_000_000 == 0  # sim time, on the pose sensor's 50 Hz grid
    # heading 0 (east), no steering, a forward force: the car moves along +x and stays on its line
    assert moved["x"] > first["x"] + 0.5 and moved["stamp_ns"] > first["stamp_ns"]
    assert abs(moved["y"] - first["y"]) < 1e-6
    # After the last command the car goes on for the watchdog's time, plus the sim time the probe's pose and its
    # last command take to cross ROS and reach a frame (at real time: a few ms of ROS and a 20 ms frame, each way;
    # 0.1 s allowed), accelerating at most at force / mass (resistances only slow it); then the watchdog brakes at
    # stop_deceleration through the brake's lag, while the drive force decays through its own (adding at most
    # force / mass * its time constant to the speed).
    sim = scenario_or_default(None).sim
    car, act = sim.vehicle, sim.vehicle.actuators
    a, hold, v0 = force / car.mass, sim.watchdog_timeout + 0.1, stopped["speed"]
    v2 = v0 + a * (hold + act.drive_time_constant)
    bound = v0 * hold + 0.5 * a * hold**2 + v2 * act.brake_time_constant + v2 * v2 / (2 * act.stop_deceleration)
    assert rest["speed"] < 0.05 and stopped["x"] < rest["x"] < stopped["x"] + bound


@pytest.mark.slow
def test_bad_messages_on_cmd_are_dropped_with_a_warning_a_second_and_commands_still_drive(ros_env, bridge,
                                                                                           tmp_path):
    n = 300
    _first, _moved, took = _probe(ros_env, "flood", str(n))
    lines = _sigint(bridge, tmp_path / "bridge.err").splitlines()
    for cause in ("a std_msgs/String is not a command", "got 1 numbers", "numbers must be finite"):
        warned = [line for line in lines if cause in line]
        assert 1 <= len(warned) <= 1 + took["seconds"], warned  # a line a second at most, of each kind
        assert all(line.startswith("WARNING vilma.record.ros1: /cmd from /vilma_probe") for line in warned)


def _header(md5: str) -> dict[str, str]:
    return {"md5sum": md5, "type": "some/Type", "callerid": "/sender"}


@given(st.lists(st.floats(), max_size=8))
def test_a_command_is_3_to_5_numbers_of_which_the_first_3_are_finite(data):
    from std_msgs.msg import Float64MultiArray

    buff = io.BytesIO()
    Float64MultiArray(data=data).serialize(buff)
    limit_ok = len(data) < 4 or math.isfinite(data[3]) or data[3] == math.inf  # inf: no limit
    if 3 <= len(data) <= 5 and all(math.isfinite(v) for v in data[:3]) and limit_ok:
        assert command_numbers(buff.getvalue(), _header(Float64MultiArray._md5sum)) == tuple(data[:4])
    else:
        with pytest.raises(CommandMessageError, match=r"^from /sender: [^\n]*$"):
            command_numbers(buff.getvalue(), _header(Float64MultiArray._md5sum))


@given(st.binary(max_size=300), st.sampled_from(["std_msgs/Float64MultiArray", "std_msgs/String", "*"]))
def test_any_bytes_of_any_type_are_a_command_or_a_one_line_refusal(buff, kind):
    from std_msgs import msg

    md5 = getattr(msg, kind.split("/")[-1])._md5sum if "/" in kind else "*"
    try:
        out = command_numbers(buff, _header(md5))
    except CommandMessageError as e:
        assert "\n" not in str(e) and e.cause in ("type", "unreadable", "length", "not finite")
    else:
        assert kind == "std_msgs/Float64MultiArray" and 3 <= len(out) <= 4
        assert all(math.isfinite(v) for v in out[:3])


def test_sigint_while_waiting_for_the_master_stops_the_bridge(tmp_path, processes):
    env = _ros_env(tmp_path, free_port())  # nobody there
    p = processes.vilma("ros1-bridge", env=env, stderr=subprocess.PIPE)
    assert "Unable to register with master node" in p.stdout.readline()  # rospy waits for it
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130 and "Traceback" not in err, err  # interrupted before it ran, as vilma's programs
