"""Two hosts: vilma sim and vilma drive in two network namespaces joined by a veth link, over Zenoh."""

from __future__ import annotations

import math
import os
import re
import shutil
import signal
import subprocess

import pytest

from tests.conftest import VILMA
from vilma.app.batch import BUNDLED
from vilma.scenario import load_scenario
from vilma.scenario.runner import run


def _netns_available() -> str | None:
    if os.geteuid() != 0:
        return "needs root to create network namespaces"
    if shutil.which("ip") is None:
        return "needs iproute2 (the ip command)"
    probe = f"vilma-probe-{os.getpid()}"
    if subprocess.run(["ip", "netns", "add", probe], capture_output=True).returncode != 0:
        return "ip netns add is not permitted here"
    subprocess.run(["ip", "netns", "delete", probe], check=True)
    return None


REASON = _netns_available()


@pytest.fixture
def two_hosts():
    """Namespaces ``sim`` (10.231.0.1) and ``drv`` (10.231.0.2), a veth between them."""
    tag = os.getpid() % 100000
    sim, drv = f"vsim{tag}", f"vdrv{tag}"
    a, b = f"vs{tag}", f"vd{tag}"
    cmds = [["ip", "netns", "add", sim], ["ip", "netns", "add", drv],
            ["ip", "link", "add", a, "type", "veth", "peer", "name", b],
            ["ip", "link", "set", a, "netns", sim], ["ip", "link", "set", b, "netns", drv]]
    for ns, dev, addr in ((sim, a, "10.231.0.1/24"), (drv, b, "10.231.0.2/24")):
        cmds += [["ip", "-n", ns, "addr", "add", addr, "dev", dev], ["ip", "-n", ns, "link", "set", dev, "up"],
                 ["ip", "-n", ns, "link", "set", "lo", "up"]]
    try:
        for c in cmds:
            subprocess.run(c, check=True, capture_output=True)
        yield sim, drv
    finally:
        for ns in (sim, drv):
            subprocess.run(["ip", "netns", "delete", ns], capture_output=True)


@pytest.mark.slow
@pytest.mark.skipif(REASON is not None, reason=f"distributed test skipped: {REASON}")
def test_sim_and_drive_on_two_hosts_follow_the_course(two_hosts, processes):
    sim_ns, drv_ns = two_hosts
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    run(scenario, compiled=False)  # fill the compiled-code cache first: the programs then start at once
    sim_at = "tcp/10.231.0.1:7447"  # a fixed port is free: the namespace is the test's own, no other program in it
    sim = processes.start("ip", "netns", "exec", sim_ns, *VILMA, "sim", "course_30kmh_stanley", "--speed", "4",
                          "--duration", "80", "--listen", sim_at)
    drive = processes.start("ip", "netns", "exec", drv_ns, *VILMA, "drive", "course_30kmh_stanley", "--connect",
                            sim_at, "--listen", "tcp/10.231.0.2:0")
    sim_out, _ = sim.communicate(timeout=240)
    drive.send_signal(signal.SIGINT)
    drive_out, _ = drive.communicate(timeout=60)
    assert sim.returncode == 0 and drive.returncode == 0, sim_out + drive_out
    assert "beyond this machine" in sim_out  # listening on a non-loopback address is warned about
    m = re.search(r"the car at x=(\S+) y=(\S+) m, speed (\S+) m/s; commands (\d+) on time", sim_out)
    x, y, speed, commands = float(m.group(1)), float(m.group(2)), float(m.group(3)), int(m.group(4))
    end = scenario.reference_path().xy[-1]
    assert commands > 1000  # the driver on the other host drove it
    assert math.hypot(x - end[0], y - end[1]) < 1.0 and speed < 0.05
