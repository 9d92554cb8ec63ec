"""Zenoh between two processes on loopback: latency, throughput, and the real-time closed loop. Prints JSON.

- ``latency``: a child process publishes an ActuatorCommand at 100 Hz for 30 s, stamped with the
  monotonic clock (shared by the processes of one machine); this process receives them: one-way latency
  from publish to callback, p50 / p99 / max [ms]. Target (issue 5): p99 < 2 ms.
- ``throughput``: the child publishes 200 000 commands as fast as it can on a reliable topic (congestion
  control: block); received per second and lost. Target: >= 100 000 msg/s, none lost.
- ``closed_loop``: ``vilma sim`` and ``vilma drive`` as two processes, real time, for 60 s of the
  course at 30 km/h: the share of the driver's commands that reached the simulator within one 20 ms
  frame of the sim time they answer (counted by the simulator). Target: >= 99.9 %.

Usage: ``python benchmarks/bus_zenoh.py [--quick]`` (``--quick``: 5 s, 20 000 messages, 15 s loop).
"""

from __future__ import annotations

import json
import re
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np

from vilma.bus import topic
from vilma.bus.zenoh_bus import ZenohBus, ZenohConfig
from vilma.core.messages import ActuatorCommand

KEY = topic("cmd", "bench")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _child(endpoint: str, mode: str, n: int) -> None:
    """The publishing process: ``rate`` (100 Hz, n messages) or ``flood`` (n messages at once)."""
    bus = ZenohBus(ZenohConfig(connect=(endpoint,)))
    time.sleep(1.0)  # let the session meet its peer and the subscription propagate
    period = 0.01
    start = time.monotonic()
    for i in range(n):
        if mode == "rate":
            time.sleep(max(0.0, start + i * period - time.monotonic()))
        bus.publish(KEY, ActuatorCommand(stamp_ns=time.monotonic_ns(), drive=float(i)))
    time.sleep(1.0)
    bus.close()


def _receive(mode: str, n: int) -> dict:
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    bus = ZenohBus(ZenohConfig(listen=(endpoint,)))
    got, done = [], threading.Event()

    def take(msg: ActuatorCommand) -> None:
        got.append((time.monotonic_ns(), msg.stamp_ns))
        if len(got) == n:
            done.set()

    bus.subscribe(KEY, take)
    child = subprocess.Popen([sys.executable, __file__, "--child", endpoint, mode, str(n)])
    done.wait(timeout=60 + n / 100 if mode == "rate" else 120)
    child.wait(timeout=30)
    bus.close()
    arr = np.array(got, dtype=np.int64)
    if mode == "rate":
        lat = (arr[:, 0] - arr[:, 1]) / 1e6
        return {"messages": n, "received": len(got), "p50_ms": round(float(np.percentile(lat, 50)), 3),
                "p99_ms": round(float(np.percentile(lat, 99)), 3), "max_ms": round(float(lat.max()), 3)}
    span = (arr[-1, 0] - arr[0, 0]) / 1e9
    return {"messages": n, "received": len(got), "lost": n - len(got),
            "messages_per_s": round(len(got) / span) if span > 0 else None}


def _closed_loop(seconds: float) -> dict:
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    cli = [sys.executable, "-m", "vilma.app.cli"]
    sim = subprocess.Popen([*cli, "sim", "course_30kmh_stanley", "--listen", endpoint], stdout=subprocess.PIPE,
                           text=True)
    time.sleep(2.0)
    drive = subprocess.Popen([*cli, "drive", "course_30kmh_stanley", "--connect", endpoint], stdout=subprocess.DEVNULL)
    time.sleep(seconds)
    drive.send_signal(signal.SIGINT)
    drive.wait()
    sim.send_signal(signal.SIGINT)
    out, _ = sim.communicate()
    # the simulator counts the commands that reached it within one frame of the sim time they answer
    m = re.search(r"commands (\d+) on time \(within a frame\), (\d+) late", out)
    on_time, late = int(m.group(1)), int(m.group(2))
    return {"seconds": seconds, "commands": on_time + late, "on_time": on_time,
            "on_time_pct": round(100.0 * on_time / (on_time + late), 3) if on_time + late else None}


def main() -> None:
    if sys.argv[1:2] == ["--child"]:
        _child(sys.argv[2], sys.argv[3], int(sys.argv[4]))
        return
    quick = "--quick" in sys.argv
    out = {"benchmark": "bus_zenoh", "zenoh_config": "peer, tcp loopback, multicast scouting off",
           "latency_100hz": _receive("rate", 500 if quick else 3000),
           "throughput": _receive("flood", 20_000 if quick else 200_000),
           "closed_loop_real_time": _closed_loop(15.0 if quick else 60.0)}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
