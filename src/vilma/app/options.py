"""What the programs' command-line options become: numbers and ports checked (argparse ``type=`` functions), a
scenario (a file, a bundled name or the defaults), a Zenoh bus. Shared by :mod:`vilma.app.cli` and the recording
commands."""

from __future__ import annotations

import argparse
import dataclasses
import ipaddress
import math
import re
from collections.abc import Callable
from pathlib import Path

from vilma.core.clock import MAX_NS, NS_PER_S

MAX_TIMER_S = (2**31 - 1) / 1000
"""Longest wall-clock delay a Qt timer takes [s] (int32 ms: 24 days)."""


def _number(text: str, ok: Callable[[float], bool], need: str, kind: type = float) -> float:
    """``text`` as a ``kind`` for which ``ok`` holds, else an argparse error saying it must be ``need``."""
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a{' whole' if kind is int else ''} number, got {text!r}") from None
    if not ok(value):
        raise argparse.ArgumentTypeError(f"must be {need}, got {text}")
    return value


def positive(text: str) -> float:
    """A finite number > 0: a speed-up factor, a time span [s], a spacing [m], a weight."""
    return _number(text, lambda v: 0 < v < math.inf, "a finite number > 0")


def non_negative(text: str) -> float:
    """A finite number >= 0: a start time [s], a weight that may be off."""
    return _number(text, lambda v: 0 <= v < math.inf, "a finite number >= 0")


def duration(text: str) -> float:
    """A run's length [s]: > 0, ``inf`` for no end."""
    return _number(text, lambda v: v > 0, "a number of seconds > 0 (inf: no end)")


def sim_time(text: str) -> float:
    """A sim time [s]: >= 0 and within what the clock counts."""
    return _number(text, lambda v: 0 <= v < MAX_NS / NS_PER_S, f"a number of seconds in [0, {MAX_NS / NS_PER_S:.3g})")


def wall_delay(text: str) -> float:
    """A wall-clock delay [s]: > 0 and at most 24 days (a Qt timer counts int32 ms)."""
    return _number(text, lambda v: 0 < v <= MAX_TIMER_S, f"a number of seconds in (0, {MAX_TIMER_S}]")


def count(text: str) -> int:
    """A whole number >= 1: a number of passes, a period [ms]."""
    return _number(text, lambda v: v >= 1, "a whole number >= 1", int)


MAX_CARS = 100_000
"""Cars one ``vilma run --cars`` may drive per run."""


def cars(text: str) -> int:
    """A number of cars, 1 .. :data:`MAX_CARS`."""
    return _number(text, lambda v: 1 <= v <= MAX_CARS, f"a whole number of cars, 1-{MAX_CARS}", int)


def port(text: str) -> int:
    """A TCP port, 1-65535."""
    return _number(text, lambda v: 1 <= v <= 65535, "a TCP port, 1-65535", int)


def port_or_any(text: str) -> int:
    """A TCP port, 1-65535, or 0 for any free one."""
    return _number(text, lambda v: 0 <= v <= 65535, "a TCP port, 1-65535, or 0 for any free port", int)


SCHEDULER_PROTOCOLS = ("tcp", "tls", "ws", "wss", "ucx")
"""The transports of a Dask scheduler's address (dask.distributed's; not ``inproc``: a scheduler in this process)."""


def scheduler(text: str) -> str:
    """A Dask scheduler's address, ``[PROTOCOL://]HOST:PORT`` (tcp by default; an IPv6 host in brackets), its port
    1-65535."""
    protocol, sep, location = text.rpartition("://")
    host, _, number = location.rpartition(":")
    if sep and protocol not in SCHEDULER_PROTOCOLS:
        raise argparse.ArgumentTypeError(f"unknown protocol {protocol!r} in {text!r}; use one of "
                                         f"{', '.join(SCHEDULER_PROTOCOLS)}, e.g. tcp://host:8786")
    if not re.fullmatch(r"[\w.-]+|\[[0-9A-Fa-f:.]+\]", host) or not number.isdecimal():  # a name, IPv4, [IPv6]
        raise argparse.ArgumentTypeError(f"expected a Dask scheduler's address, HOST:PORT or tcp://HOST:PORT (as "
                                         f"`dask scheduler` prints it), got {text!r}")
    if not 1 <= int(number) <= 65535:
        raise argparse.ArgumentTypeError(f"port {number} of {text!r} must be a TCP port, 1-65535")
    return text


def listen_endpoint(text: str) -> str:
    """A Zenoh endpoint to listen on (port 0: any free one)."""
    return _endpoint(text, listen=True)


def connect_endpoint(text: str) -> str:
    """A Zenoh endpoint to connect to."""
    return _endpoint(text, listen=False)


def _endpoint(text: str, listen: bool) -> str:
    from vilma.core.net import check_endpoint

    try:
        check_endpoint(text, listen)
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"{text!r}: {e}") from None
    return text


def bind_address(text: str) -> str:
    """An IP address of this machine to listen on (``[v6]`` too; ``localhost``; 0.0.0.0 or :: for all)."""
    host = text.strip("[]")
    if host != "localhost":
        try:
            ipaddress.ip_address(host)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an IP address; give one of this machine, e.g. "
                                             "127.0.0.1 (0.0.0.0 or :: for all its interfaces)") from None
    return host


def first_stream_port(text: str) -> int:
    """The first port of the MORSE datastreams, which take consecutive ports from it: room for every one up to
    65535, or 0 for any free ports."""
    from vilma.morse import COMPONENTS

    top = 65536 - len(COMPONENTS)
    return _number(text, lambda v: 0 <= v <= top, f"a TCP port, 1-{top} (the {len(COMPONENTS)} datastreams take "
                   "consecutive ports from it), or 0 for any free ports", int)


def scenario_or_default(name: str | None, task: str = "task: {speed: 0.0001}", plant: str | None = None):
    """The scenario named (file or bundled), else the defaults with an idle task; ``plant`` overrides its plant."""
    from vilma.scenario.fields import load_yaml
    from vilma.scenario.spec import load_scenario, parse_scenario

    overrides = {"plant": plant} if plant else None
    if name:
        return load_scenario(name, overrides)
    data, src = load_yaml(task, "defaults")
    return parse_scenario(data, src, name="defaults", overrides=overrides)


def zenoh_bus(args: argparse.Namespace, listen_default: tuple[str, ...], connect_default: tuple[str, ...]):
    """A Zenoh bus from ``--listen``, ``--connect`` and ``--zenoh-config`` (else the defaults), and its config."""
    from vilma.bus.zenoh_bus import ZenohBus, ZenohConfig

    cfg = ZenohConfig(listen=listen_default, connect=connect_default)
    if args.zenoh_config:
        cfg = zenoh_config_file(Path(args.zenoh_config), cfg)
    if args.listen is not None:
        cfg = dataclasses.replace(cfg, listen=tuple(args.listen))
    if args.connect is not None:
        cfg = dataclasses.replace(cfg, connect=tuple(args.connect))
    return ZenohBus(cfg), cfg


def zenoh_config_file(path: Path, base):
    """The :class:`~vilma.bus.zenoh_bus.ZenohConfig` ``base`` with the values of the YAML file ``path``: ``listen``
    and ``connect`` (lists of endpoints), ``multicast_scouting`` (true or false), ``extra`` (a list of [key path,
    JSON5 value] pairs). An error names the file, the line and the field, never what the file holds: a file given
    by mistake (``/etc/passwd``) is not shown.

    Raises:
        ValueError: a file that cannot be read or holds anything else, in one line.
    """
    from vilma.core.net import check_endpoint
    from vilma.scenario.fields import read_yaml

    data, src = read_yaml(path)
    fields = ("listen", "connect", "multicast_scouting", "extra")
    if not isinstance(data, dict | None):
        raise ValueError(f"{path}: not a Zenoh configuration: expected a mapping of {', '.join(fields)}")
    values = {}
    for key, value in (data or {}).items():
        where = src.where((key,))
        if key == "multicast_scouting":
            if not isinstance(value, bool):
                raise ValueError(f"{where}: {key}: expected true or false")
            values[key] = value
        elif key == "extra":
            if not (isinstance(value, list) and all(isinstance(pair, list) and len(pair) == 2
                                                    and all(isinstance(v, str) for v in pair) for pair in value)):
                raise ValueError(f"{where}: {key}: expected a list of [key path, JSON5 value] pairs of text")
            values[key] = tuple(tuple(pair) for pair in value)
        elif key in fields:
            if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
                raise ValueError(f"{where}: {key}: expected a list of endpoints, e.g. [tcp/127.0.0.1:7447]")
            for i, endpoint in enumerate(value):
                try:
                    check_endpoint(endpoint, key == "listen")
                except ValueError as e:
                    raise ValueError(f"{src.where((key, i))}: {key}[{i}]: {e}") from None
            values[key] = tuple(value)
        else:
            raise ValueError(f"{where}: unknown key; the keys are {', '.join(fields)}")
    return dataclasses.replace(base, **values)


PLANT_HELP = "the car's model instead of the scenario's: kinematic, single_track or mujoco (the 3D plant)"


def plant(name: str) -> str:
    """``--plant``: a planar model's name or ``mujoco``."""
    from vilma.sim.config import MUJOCO
    from vilma.vehicle.models import MODELS

    if name not in (*MODELS, MUJOCO):
        raise argparse.ArgumentTypeError(f"unknown plant {name!r}; use one of {', '.join(MODELS)}, {MUJOCO}")
    return name


def out_folder(name: str) -> Path:
    """Where a command writes (``--out``): any path but an empty one, which would quietly mean the default."""
    if not name:
        raise argparse.ArgumentTypeError("empty; give a folder, or no --out for the default")
    return Path(name)


def folder(name: str) -> Path:
    """A folder that exists."""
    if not Path(name).is_dir():
        raise argparse.ArgumentTypeError(f"{name!r} is not a folder; create it or give another")
    return Path(name)


def complete_scenario(prefix: str, **_) -> list[str]:
    """Shell completion of a scenario: the bundled names, and files and folders (argcomplete's completer)."""
    from argcomplete.completers import FilesCompleter

    from vilma.scenario import bundled

    return [n for n in bundled.names() if n.startswith(prefix)] + list(FilesCompleter(("yaml",))(prefix))
