"""What the programs' command-line options become: a speed factor checked, a scenario (a file, a bundled name
or the defaults), a Zenoh bus. Shared by :mod:`vilma.cli` and the recording commands."""

from __future__ import annotations

import argparse


def check_factor(value: float | None, option: str) -> None:
    """A speed-up factor option (``--speed``, ``--realtime``) must be positive and finite."""
    if value is not None and not 0 < value < float("inf"):
        raise ValueError(f"{option} must be a positive factor, got {value:g}")


def scenario_or_default(name: str | None, task: str = "task: {speed: 0.0001}", plant: str | None = None):
    """The scenario named (file or bundled), else the defaults with an idle task; ``plant`` overrides its plant."""
    from vilma.scenario import batch
    from vilma.scenario.fields import load_yaml
    from vilma.scenario.spec import load_scenario, parse_scenario

    overrides = {"plant": plant} if plant else None
    if name:
        return load_scenario(batch.find_scenario(name), overrides)
    data, src = load_yaml(task, "defaults")
    return parse_scenario(data, src, name="defaults", overrides=overrides)


def zenoh_bus(args: argparse.Namespace, listen_default: tuple[str, ...], connect_default: tuple[str, ...]):
    """A Zenoh bus from ``--listen``, ``--connect`` and ``--zenoh-config`` (else the defaults), and its config."""
    import dataclasses
    from pathlib import Path

    from vilma.bus.zenoh_bus import ZenohBus, ZenohConfig
    from vilma.scenario.fields import build, read_yaml

    cfg = ZenohConfig(listen=listen_default, connect=connect_default)
    if args.zenoh_config:  # a YAML file with listen, connect, multicast_scouting
        data, src = read_yaml(Path(args.zenoh_config))
        cfg = build(ZenohConfig, data, src, base=cfg)
    if args.listen is not None:
        cfg = dataclasses.replace(cfg, listen=tuple(args.listen))
    if args.connect is not None:
        cfg = dataclasses.replace(cfg, connect=tuple(args.connect))
    return ZenohBus(cfg), cfg
