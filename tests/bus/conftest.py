"""Bus test helpers: a driver node alone, and a data folder with files a peer must not get."""

from __future__ import annotations

import os
import socket
from pathlib import Path

from vilma.app.batch import BUNDLED
from vilma.bus.nodes import DriverNode
from vilma.control.driver import Driver
from vilma.scenario import load_scenario
from vilma.trajectory.io import MAX_FILE_BYTES

SECRET = "hunter2"
"""What the files a peer must not read hold (not a number: a parser quoting it would show it)."""


def driver_on(bus, data_dir: Path | None = None) -> DriverNode:
    """A driver node (no simulator: orders need none) on ``bus``, following files of ``data_dir``."""
    scenario = load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    driver = Driver(scenario.sim.vehicle, scenario.driver, step=scenario.sim.step)
    return DriverNode(driver, bus, step_ns=round(scenario.sim.step * 1e9), data_dir=data_dir)


def data_folder(root: Path) -> Path:
    """``root/data``, beside ``root/secret.txt``: good.csv (a 30 m straight at 2 m/s), same.csv (a link to it),
    bad.txt (quotes the secret on line 2), big.txt (sparse, 1 byte over the cap), a pipe, a folder, a link to
    itself, and links out (to the secret and to /dev/zero)."""
    (root / "secret.txt").write_text(f"{SECRET} 1\n2 3\n")
    data = root / "data"
    (data / "sub").mkdir(parents=True)
    (data / "good.csv").write_text("x,y,speed\n0,0,2\n30,0,2\n")
    (data / "same.csv").symlink_to("good.csv")
    (data / "bad.txt").write_text(f"0 0\n{SECRET} 1\n")
    with open(data / "big.txt", "wb") as f:
        f.truncate(MAX_FILE_BYTES + 1)
    os.mkfifo(data / "pipe")
    (data / "secret.txt").symlink_to(root / "secret.txt")
    (data / "zero").symlink_to("/dev/zero")
    (data / "loop").symlink_to("loop")
    return data


def free_endpoint() -> str:
    """A Zenoh TCP endpoint on a free loopback port."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{s.getsockname()[1]}"
