"""A scenario's simulation keys: the car (``vehicle``, ``actuators``), the ``plant`` and its ``world``, the 3D
plant's ``cameras``, the ``laser`` (also on flat ground), the ``objects`` sensor, the ``sensors``, and the times
they run at, read into a :class:`~vilma.sim.SimConfig` (:func:`read_sim`, called by
:func:`vilma.scenario.spec.parse_scenario`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from vilma.core.clock import Clock, RateError, seconds_to_ns
from vilma.core.geodesy import GeodeticOrigin
from vilma.plant3d.camera import CameraParams, stereo_pair
from vilma.plant3d.laser import LaserParams
from vilma.plant3d.world import World
from vilma.scenario.fields import Key, Source, SpecError, build, convert, get, read_yaml
from vilma.sensors import SensorSuite
from vilma.sensors.objects import ObjectsParams
from vilma.sim import SimConfig
from vilma.sim.config import MUJOCO
from vilma.vehicle import models
from vilma.vehicle.params import PRESETS, ActuatorParams, VehicleParams, preset

ROAD_KEYS = ("commonroad", "planning_problem")
"""The ``world`` keys of a CommonRoad scenario (the others are the 3D plant's)."""
SWITCHED = ("laser", "objects")
"""The sections that ``true`` switches on with their defaults (:func:`_optional`)."""


def read_sim(data: dict, src: Source, base: Path) -> SimConfig:
    """The simulator's sections, ``vehicle`` to ``origin``; ``base`` is the folder of a vehicle file."""
    vehicle = _vehicle(data.get("vehicle", "vilma"), src, base)
    if "actuators" in data:
        vehicle = dataclasses.replace(vehicle, actuators=build(ActuatorParams, data["actuators"], src, ("actuators",),
                                                                vehicle.actuators))
    model = get(data, src, ("plant",), str, "single_track")
    if model not in (*models.MODELS, MUJOCO):
        raise src.error(("plant",), f"unknown plant {model!r}; use one of {', '.join(models.MODELS)}, {MUJOCO}")
    world = build(World, data.get("world"), src, ("world",), World(), others=ROAD_KEYS)
    cameras = _cameras(data.get("cameras"), src)
    laser, objects = _optional(LaserParams, data, src, "laser"), _optional(ObjectsParams, data, src, "objects")
    integrator, step = get(data, src, ("integrator",), str, "rk4"), get(data, src, ("step",), float, 0.01)
    seed, watchdog_timeout = get(data, src, ("seed",), int, 0), get(data, src, ("watchdog_timeout",), float, 0.5)
    if seed < 0:
        raise src.error(("seed",), f"{seed} is not a seed: give a whole number >= 0")
    sensors = _sensors(data, src)
    try:
        sim = SimConfig(vehicle=vehicle, model=model, integrator=integrator, step=step, sensors=sensors, seed=seed,
                        watchdog_timeout=watchdog_timeout, world=world, cameras=cameras, laser=laser,
                        objects=objects)
    except ValueError as e:  # SimConfig checks the keys together; its message names the one at fault
        culprit = next((k for k, word in (("step", "step"), ("integrator", "integrator"),
                                          ("watchdog_timeout", "watchdog"), ("world", "world"),
                                          ("cameras", "camera"), ("laser", "laser")) if word in str(e)), None)
        raise src.error((culprit,) if culprit else (), str(e)) from None
    check_sim_times(sim, src)
    if model != MUJOCO and (world.boxes or world.cones):  # obstacles standing still, which the scene sensors see
        sim = dataclasses.replace(sim, traffic=world.traffic())
    return sim


def _optional(cls: type, data: dict, src: Source, key: str) -> Any:
    """An optional sensor ``key``: absent or false for none, true for the defaults, or a mapping of fields."""
    value = data.get(key)
    return build(cls, {} if value is True else value, src, (key,)) if value not in (None, False) else None


def _vehicle(value: Any, src: Source, base: Path) -> VehicleParams:
    """``vehicle``: a preset name, a parameter file (relative to ``base``) or a mapping of fields."""
    key: Key = ("vehicle",)
    if isinstance(value, str) and value.endswith((".yaml", ".yml")):
        try:
            data, src = read_yaml(base / value)
        except SpecError as e:
            raise src.error(key, str(e)) from None
        key = ()
    else:
        data = value
    if isinstance(data, str):
        if data not in PRESETS:
            raise src.error(key, f"unknown vehicle preset {data!r}; use one of {', '.join(PRESETS)} or a .yaml file")
        return preset(data)
    if not isinstance(data, dict):
        raise src.error(key, "expected a preset name, a .yaml parameter file or a mapping of vehicle parameters")
    data = dict(data)
    start = data.pop("preset", None)
    if start is not None and start not in PRESETS:
        raise src.error((*key, "preset"), f"unknown vehicle preset {start!r}; use one of {', '.join(PRESETS)}")
    return build(VehicleParams, data, src, key, preset(start) if start else None)


def _cameras(raw: Any, src: Source) -> tuple[CameraParams, ...]:
    """``cameras``: a list of camera mappings, or ``{stereo: {baseline, <camera fields>}}``."""
    if raw is None:
        return ()
    if isinstance(raw, list):
        return tuple(build(CameraParams, c, src, ("cameras", i)) for i, c in enumerate(raw))
    if isinstance(raw, dict) and list(raw) == ["stereo"]:
        key = ("cameras", "stereo")
        common = dict(raw["stereo"] or {})
        baseline = convert(float, common.pop("baseline"), src, (*key, "baseline")) if "baseline" in common else 0.3
        centre = build(CameraParams, common, src, key)
        try:
            return stereo_pair(baseline, **{f.name: getattr(centre, f.name) for f in dataclasses.fields(centre)
                                            if f.name != "name"})
        except ValueError as e:
            raise src.error((*key, "baseline"), str(e)) from None
    raise src.error(("cameras",), "expected a list of cameras, or {stereo: {baseline: 0.3}} for the front pair")



def _sensors(data: dict, src: Source) -> SensorSuite:
    """``sensors``, with the gps sensor's ``origin``."""
    sensors = build(SensorSuite, data.get("sensors"), src, ("sensors",), SensorSuite())
    if "origin" in data:
        origin = build(GeodeticOrigin, data["origin"], src, ("origin",))
        if sensors.gps is None:
            raise src.error(("origin",), "an origin needs the gps sensor; remove 'origin' or 'sensors.gps: false'")
        sensors = dataclasses.replace(sensors, gps=dataclasses.replace(sensors.gps, origin=origin))
    return sensors


def check_sim_times(sim: SimConfig, src: Source) -> None:
    """Every sensor rate must be a whole number of physics steps, every time within the clock's range."""
    clock = Clock(seconds_to_ns(sim.step))
    for key, seconds in ((("watchdog_timeout",), sim.watchdog_timeout),
                         (("actuators", "dead_time"), sim.vehicle.actuators.dead_time)):
        try:
            clock.ticks_for(seconds)
        except ValueError as e:
            raise src.error(key, str(e)) from None
    for f in dataclasses.fields(SensorSuite):
        sensor = getattr(sim.sensors, f.name)
        if sensor is not None:
            try:
                clock.period_ticks(sensor.rate_hz, f"sensor {f.name}")
            except RateError as e:
                raise src.error(("sensors", f.name, "rate_hz"), str(e)) from None
    for key, sensor in [*((("cameras", i), c) for i, c in enumerate(sim.cameras)), (("laser",), sim.laser),
                        (("objects",), sim.objects)]:
        if sensor is not None:
            try:
                clock.period_ticks(sensor.rate_hz, key[0] if key == ("objects",) else sensor.name)
            except RateError as e:
                raise src.error((*key, "rate_hz"), str(e)) from None
