"""A scenario's driver: the ``driver``, ``speed_controller``, ``path_controller`` and ``pose`` sections
(:mod:`vilma.scenario.spec` reads the rest), and the driver's period they give."""

from __future__ import annotations

import dataclasses
import math

from vilma.control import registry
from vilma.control.driver import DriverParams
from vilma.core.clock import Clock, RateError, seconds_to_ns
from vilma.localization import SOURCES
from vilma.scenario.fields import Source, _suggest, build, convert
from vilma.sim import SimConfig


def read_driver(data: dict, src: Source) -> DriverParams:
    """The driver's sections: ``driver``, ``speed_controller``, ``path_controller`` and ``pose``."""
    raw = data.get("driver") or {}
    if not isinstance(raw, dict):
        raise src.error(("driver",), "expected a mapping of driver parameters")
    raw = dict(raw)
    original = convert(bool, raw.pop("original", False), src, ("driver", "original"))
    keys = {**{f.name: f for f in dataclasses.fields(DriverParams) if f.name != "gains"},
            **dict.fromkeys(registry.names())}  # the driver's fields, and controller gains by name
    for name in raw:
        if isinstance(name, str) and name not in keys:
            raise src.error(("driver", name), f"unknown key{_suggest(name, keys)}")
    named = {name: raw.pop(name) for name in registry.names() if name in raw}
    params = build(DriverParams, raw, src, ("driver",), DriverParams.original() if original else DriverParams())
    for name, value in named.items():
        params = params.with_gains({name: build(registry.controller_type(name).params, value, src, ("driver", name),
                                                params.gains_of(name))})
    for key, known in (("speed_controller", registry.names(registry.SPEED)),
                       ("path_controller", registry.names(registry.PATH))):
        if key not in data:
            continue
        value = data[key]
        gains: dict = {}
        if isinstance(value, dict):  # gains, of the type named, else of the driver's (--set speed_controller.kp=2)
            gains = dict(value)
            value = gains.pop("type", getattr(params, key))
        if value not in known:
            raise src.error((key,), f"unknown {key} {value!r}; use one of {', '.join(known)}")
        gains_key = (key,)  # gains sit beside 'type' in the file
        current = params.gains_of(value)
        params = dataclasses.replace(params, **{key: value}).with_gains(
            {value: build(type(current), gains, src, gains_key, current)})
    if "pose" in data:
        pose = convert(str, data["pose"], src, ("pose",))
        if pose not in SOURCES:
            raise src.error(("pose",), f"unknown pose source {pose!r}; use one of {', '.join(SOURCES)}")
        params = dataclasses.replace(params, pose_source=pose)
    return params


def driver_period(driver: DriverParams, sim: SimConfig, src: Source) -> float:
    """The driver's period [s] (the gcd of its controllers'); each must be a whole number of physics steps."""
    clock = Clock(seconds_to_ns(sim.step))
    ticks = []
    for key in ("speed_controller", "path_controller"):
        name = getattr(driver, key)
        try:
            ticks.append(clock.period_ticks(1.0 / driver.gains_of(name).period, f"{name} period"))
        except RateError as e:
            raise src.error((key, "period"), str(e)) from None
    return math.gcd(*ticks) * clock.step_s
