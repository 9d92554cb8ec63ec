"""``vilma ros1-bridge`` on a real ROS 1 master: a rospy subscriber gets the car's pose, a command moves the car.

Skipped where ROS 1 is not installed (Debian: ros-core python3-rospy python3-geometry-msgs python3-sensor-msgs
python3-std-msgs); .ci/run installs it.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from vilma.record.ros1 import rospy_or_reason

rospy, WHY = rospy_or_reason()  # the ROS side runs in ros1_probe.py, its own process
pytestmark = [
    pytest.mark.skipif(rospy is None, reason=WHY),
    pytest.mark.skipif(shutil.which("roscore") is None, reason="ROS 1 is not installed: no roscore on PATH "
                       "(apt-get install ros-core)"),
]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def ros_env(tmp_path):
    port = _free_port()
    env = {**os.environ, "ROS_MASTER_URI": f"http://127.0.0.1:{port}", "ROS_IP": "127.0.0.1",
           "ROS_HOSTNAME": "127.0.0.1", "ROS_HOME": str(tmp_path / "ros"), "ROS_LOG_DIR": str(tmp_path / "log")}
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
        core.terminate()
        core.communicate(timeout=20)


def test_bridge_publishes_pose_and_a_ros_command_moves_the_car(ros_env):
    bridge = subprocess.Popen([sys.executable, "-m", "vilma.cli", "ros1-bridge", "--speed", "1"], env=ros_env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        force = 3000.0  # forward drive force [N], wheels straight
        probe = subprocess.run([sys.executable, str(Path(__file__).with_name("ros1_probe.py")), str(force)],
                               env=ros_env, capture_output=True, text=True, timeout=180)
    finally:
        bridge.terminate()
        _, err = bridge.communicate(timeout=30)
    assert probe.returncode == 0, probe.stderr + err
    first, moved = (json.loads(line) for line in probe.stdout.splitlines())
    assert first["frame"] == "/map"
    assert first["stamp_ns"] % 20_000_000 == 0  # sim time, on the pose sensor's 50 Hz grid
    # heading 0 (east), no steering, a forward force: the car moves along +x and stays on its line
    assert moved["x"] > first["x"] + 0.5 and moved["stamp_ns"] > first["stamp_ns"]
    assert abs(moved["y"] - first["y"]) < 1e-6
    assert bridge.returncode == 0 and "Traceback" not in err
