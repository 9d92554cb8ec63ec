"""Scenario files: defaults, every bundled file, round trips, overrides and located errors."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.app.batch import BUNDLED
from vilma.app.options import zenoh_bus
from vilma.control.path.vilma_heading import VilmaHeadingParams
from vilma.control.speed.pi_ff import PiFfParams
from vilma.plant3d.laser import LaserParams
from vilma.scenario import SpecError, load_scenario, parse_scenario, to_yaml
from vilma.scenario.drive_log import MAX_ROWS
from vilma.scenario.fields import MAX_YAML_VALUES, load_yaml
from vilma.scenario.spec import Bound
from vilma.sensors import SensorSuite
from vilma.sensors.objects import ObjectsParams
from vilma.trajectory.points import MAX_POINTS
from vilma.vehicle.params import preset, vilma

FIVE_LINES = """\
task:
  course: [[0, 0], [100, 0], [100, -30], [50, -20], [60, 0]]
  speed: 8.33
speed_controller: pi_ff
path_controller: stanley
"""


def _write(tmp_path: Path, text: str, name: str = "s.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_a_five_line_file_gets_sensible_defaults(tmp_path):
    s = load_scenario(_write(tmp_path, FIVE_LINES))
    assert s.name == "s" and s.task.kind == "course" and s.task.speed == 8.33
    assert s.sim.vehicle == vilma() and s.sim.model == "single_track" and s.sim.step == 0.01
    assert s.sim.sensors == SensorSuite() and s.driver.pose_source == "truth"
    assert (s.driver.speed_controller, s.driver.path_controller) == ("pi_ff", "stanley")
    assert s.metrics.skip == 2.0 and s.expect == {}


def test_everything_can_be_set(tmp_path):
    (tmp_path / "car.yaml").write_text("preset: bmw_320i\nmass: 1500\n", encoding="utf-8")
    (tmp_path / "p.txt").write_text("0 0\n10 0\n20 5\n", encoding="utf-8")
    s = load_scenario(_write(tmp_path, """\
name: full
vehicle: car.yaml
actuators: {dead_time: 0.1}
plant: kinematic
step: 0.005
seed: 7
sensors: {odometry: false, gps: {rate_hz: 5, horizontal_noise: 0.3}}
origin: {latitude: 48.1, longitude: 11.6, altitude: 500}
pose: ekf
speed_controller: {type: pi_ff, kp: 1.5}
path_controller: {type: pure_pursuit, lookahead_min: 4}
driver: {max_lateral_accel: 3.0}
task: {follow: p.txt, speed: 4, densify: 2, smooth: {beta: 0.2}, resample: 0.5}
initial: {yaw: 0.1}
duration: 30
metrics: {skip: 1}
expect: {completed: true, lateral_error_rms_m: {max: 0.2}}
"""))
    v = s.sim.vehicle
    assert v.name.lower().startswith("bmw") and v.mass == 1500 and v.actuators.dead_time == 0.1
    assert s.sim.model == "kinematic" and s.sim.step == 0.005 and s.sim.seed == 7
    assert s.sim.sensors.odometry is None and s.sim.sensors.gps.rate_hz == 5
    assert s.sim.sensors.gps.origin.latitude == 48.1
    assert s.driver.pose_source == "ekf" and s.driver.gains_of("pi_ff") == PiFfParams(kp=1.5)
    assert s.driver.path_controller == "pure_pursuit" and s.driver.gains_of("pure_pursuit").lookahead_min == 4
    assert s.driver.max_lateral_accel == 3.0 and s.initial.yaw == 0.1 and s.duration == 30
    assert s.expect == {"completed": True, "lateral_error_rms_m": Bound(max=0.2)}
    path = s.reference_path()
    # 3 points, Generate Points twice: 3 -> 5 -> 9 points; then resampled every 0.5 m
    assert path.length == pytest.approx(10 + 5 * 5**0.5, rel=0.05)
    gaps = np.diff(path.s)
    assert np.allclose(gaps[:-1], 0.5, atol=1e-3) and gaps[-1] <= 0.5 + 1e-9  # chords of 0.5 m arcs


@pytest.mark.parametrize("path", sorted(BUNDLED.glob("*.yaml")), ids=lambda p: p.stem)
def test_bundled_scenarios_load_and_round_trip(path, tmp_path, monkeypatch):
    s = load_scenario(path)
    assert s.name == path.stem and s.description
    text = to_yaml(s)
    monkeypatch.delattr(yaml, "CSafeDumper")
    assert to_yaml(s) == text  # libyaml's dumper writes what PyYAML's own does
    again = load_scenario(_write(tmp_path, text, "resolved.yaml"))
    if s.task.follow:  # the resolved file names the trajectory by its absolute path
        assert again.trajectory_file() == s.trajectory_file().resolve()
        again = dataclasses.replace(again, task=s.task)
    if s.speed_log:
        assert Path(again.speed_log) == (path.parent / s.speed_log).resolve()
        again = dataclasses.replace(again, speed_log=s.speed_log)
    assert dataclasses.replace(again, file=None) == dataclasses.replace(s, file=None)
    if s.task.kind in ("follow", "course"):
        assert len(s.reference_path()) > 10


def test_overrides_set_nested_values_and_controller_gains(tmp_path):
    p = _write(tmp_path, FIVE_LINES)
    s = load_scenario(p, {"task.speed": "5", "speed_controller.kp": "2.5", "sensors.gps": "false", "pose": "truth"})
    assert s.task.speed == 5.0 and s.driver.gains_of("pi_ff").kp == 2.5 and s.sim.sensors.gps is None
    with pytest.raises(SpecError, match=r"^--set task\.speed=fast: task\.speed: expected a number, got 'fast'$"):
        load_scenario(p, {"task.speed": "fast"})
    with pytest.raises(SpecError, match=r"^--set task\.speed\.x=1: task\.speed is not a mapping"):
        load_scenario(p, {"task.speed.x": "1"})


def test_an_error_on_a_section_names_the_set_values_within_it(tmp_path):
    p = _write(tmp_path, "task:\n  course: [[0, 0], [10, 0]]\n  speed: 5\n")
    with pytest.raises(SpecError, match=r"^--set task\.speed=: task\.speed: speed is missing"):
        load_scenario(p, {"task.speed": ""})  # (an empty value is YAML's null: the task's check refuses it)
    with pytest.raises(SpecError, match=r"s\.yaml:1 \(--set nosuch\.key=1\): nosuch: unknown key"):
        load_scenario(p, {"nosuch.key": "1"})


def test_a_vehicle_value_set_changes_the_scenarios_preset(tmp_path):
    named, default = _write(tmp_path, "task: {speed: 5}\nvehicle: bmw_320i\n"), _write(tmp_path, "task: {speed: 5}\n",
                                                                                        "d.yaml")
    assert load_scenario(named, {"vehicle.mass": "2000"}).sim.vehicle == dataclasses.replace(preset("bmw_320i"),
                                                                                           mass=2000.0)
    assert load_scenario(default, {"vehicle.mass": "2000"}).sim.vehicle == dataclasses.replace(vilma(), mass=2000.0)


def test_a_value_set_in_a_sensor_switched_on_by_true_changes_its_defaults(tmp_path):
    on = _write(tmp_path, "task: {speed: 5}\nlaser: true\nobjects: true\n")
    s = load_scenario(on, {"laser.rate_hz": "20", "objects.range": "30"})
    assert s.sim.laser == LaserParams(rate_hz=20.0) and s.sim.objects == ObjectsParams(range=30.0)
    off = _write(tmp_path, "task: {speed: 5}\nlaser: false\n", "off.yaml")
    with pytest.raises(SpecError, match=r"^--set laser\.rate_hz=20: laser is not a mapping"):
        load_scenario(off, {"laser.rate_hz": "20"})  # (switched off: not switched on by a value set in it)


@pytest.mark.parametrize(("text", "message"), [
    ("speed_controller: pi_ff\n", "s.yaml:1: no task"),
    ("task: {speed: 5}\nvehicle: tesla\n", "s.yaml:2: vehicle: unknown vehicle preset 'tesla'"),
    ("task: {speed: 5}\nvehicle: car.yaml\n", "s.yaml:2: vehicle: "),  # (then the file's whole path: no such file)
    ("task: {speed: 5}\nseed: -1\n", "s.yaml:2: seed: -1 is not a seed: give a whole number >= 0"),
    ("task: {speed: 5}\nactuators: {dead_time: -1}\n",
     "s.yaml:2: actuators.dead_time: actuator dead_time must be a finite number >= 0, got -1.0"),
    ("task: {speed: 5}\nsensors: {gps: {horizontal_noise: -1}}\n",
     "s.yaml:2: sensors.gps.horizontal_noise: sensor gps horizontal_noise must be a finite number >= 0, got -1.0"),
    ("task: {speed: 5}\nsensors: {imu: {bias_tau: 0}}\n",
     "s.yaml:2: sensors.imu.bias_tau: sensor imu bias_tau must be a finite number > 0, got 0.0"),
    ("task: {speed: 5}\nvehicle: {preset: vilma, mas: 1}\n", "s.yaml:2: vehicle.mas: unknown key; did you mean 'mass'"),
    ("task: {speed: 5}\nplant: bullet\n", "s.yaml:2: plant: unknown plant 'bullet'"),
    ("task: {speed: 5}\nstep: 0.02\n", "s.yaml:2: step: physics step must be in [0.0001, 0.01] s"),
    ("task: {speed: 5}\nsensors: {imu: {rate_hz: 30}}\n",
     "s.yaml:2: sensors.imu.rate_hz: sensor imu: 30 Hz is a period of 33.3333 ms, not a whole multiple"),
    ("task: {speed: 5}\npose: gps\n", "s.yaml:2: pose: unknown pose source 'gps'"),
    ("task: {speed: 5}\nspeed_controller: {type: pid}\n", "s.yaml:2: speed_controller: unknown speed_controller 'pid'"),
    ("task: {speed: 5}\nspeed_log: missing.txt\n", "s.yaml:2: speed_log: "),  # (then the file's whole path)
    ("task: {speed: 5}\npath_controller: mpc\n", "s.yaml:2: path_controller: unknown path_controller 'mpc'"),
    ("task: {speed: 5}\ndriver: {stanly: {gain: 1}}\n",
     "s.yaml:2: driver.stanly: unknown key; did you mean 'stanley'?"),
    ("task: {speed: 5}\ndriver: {stanley: {gian: 1}}\n",
     "s.yaml:2: driver.stanley.gian: unknown key; did you mean 'gain'?"),
    ("task: {speed: 5}\ndriver: {gains: []}\n", "s.yaml:2: driver.gains: unknown key"),
    ("task: {speed: 5}\ndriver: {max_lateral_accel: -2}\n",
     "s.yaml:2: driver.max_lateral_accel: driver max_lateral_accel must be a finite number > 0 m/s^2, got -2.0"),
    ("task: {speed: 5, go_to: [1, 2], course: [[0, 0], [1, 1]]}\n",
     "s.yaml:1: task.go_to: give one of go_to, follow, course, not go_to and course"),
    ("task: {course: [[0, 0], [1, 1]]}\n", "s.yaml:1: task: speed is missing"),
    ("task: {course: [[0, 0], [5, 0], [5, 0]], speed: 5}\n",
     "s.yaml:1: task.course[2]: the same point as the one before: a course's points must differ"),
    ("task: {course: [[0, 0], [1e7, 0]], speed: 5}\n", "s.yaml:1: task.course: 1e+07 m long, more than the 500 km"),
    ("task: {course: [[0, 0], [1e300, 0], [-1e300, 0]], speed: 5}\n", "s.yaml:1: task.course: 3e+300 m long"),
    ("task: {follow: missing.txt, speed: 2}\n", "s.yaml:1: task.follow: no such trajectory file"),
    ("task: {speed: 5}\nduration: 0\n", "s.yaml:2: duration: must be > 0 s"),
    ("task: {speed: 5}\nexpect: {lateral_error: {max: 1}}\n", "s.yaml:2: expect.lateral_error: not a scorecard key"),
    ("task: {speed: 5}\nexpect: {distance_m: {}}\n", "s.yaml:2: expect.distance_m: give min, max or both"),
    ("task: {speed: 5}\nsensors: {gps: false}\norigin: {latitude: 1, longitude: 2}\n",
     "s.yaml:3: origin: an origin needs the gps sensor"),
    ("task: {speed: 5}\nspeeed: 3\n", "s.yaml:2: speeed: unknown key; did you mean 'seed'? (known: name, description"),
    ("task: {speed: 5}\nspeed_controler: pi_ff\n", "s.yaml:2: speed_controler: unknown key; did you mean "
                                                     "'speed_controller'?"),
])
def test_bad_files_give_one_located_line(tmp_path, text, message):
    _refused_on_one_line(tmp_path, text, message)


@pytest.mark.parametrize(("text", "message"), [
    ("task: {speed: 5}\nplant: bullet\nsensors: 3\n", "s.yaml:2: plant: unknown plant 'bullet'"),
    ("task: {speed: 5}\nsensors: {imu: {rate_hz: 30}}\npath_controller: mpc\n",
     "s.yaml:2: sensors.imu.rate_hz: sensor imu: 30 Hz"),
    ("task: {follow: missing.txt, speed: 2}\nduration: 0\n", "s.yaml:1: task.follow: no such trajectory file"),
])
def test_of_two_errors_the_first_section_in_reading_order_is_named(tmp_path, text, message):
    """The sections are read once, top-down in the order of TOP_KEYS, each checked as it is read."""
    _refused_on_one_line(tmp_path, text, message)


def test_the_driver_section_takes_controllers_and_their_gains_by_name(tmp_path):
    s = load_scenario(_write(tmp_path, "task: {speed: 5}\n"
                                       "driver: {path_controller: pure_pursuit, pure_pursuit: {lookahead_min: 4},\n"
                                       "         stanley: {gain: 3}}\n"))
    assert s.driver.path_controller == "pure_pursuit" and s.driver.gains_of("pure_pursuit").lookahead_min == 4
    assert s.driver.gains_of("stanley").gain == 3  # kept for a later swap
    assert s.driver.gains_of("vilma_heading") == VilmaHeadingParams()  # never named: the defaults


def _refused_on_one_line(tmp_path, text: str, message: str) -> None:
    with pytest.raises(SpecError) as e:
        load_scenario(_write(tmp_path, text))
    assert str(e.value).startswith(str(tmp_path / message)), str(e.value)
    assert "\n" not in str(e.value)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(SpecError, match="no such file"):
        load_scenario(tmp_path / "nope.yaml")
    p = tmp_path / "bin.yaml"
    p.write_bytes(b"\xff\xfe\x00task")
    with pytest.raises(SpecError, match="not a text file"):
        load_scenario(p)


def test_a_missing_commonroad_file_is_named_before_the_roads_extra(tmp_path, monkeypatch):
    """A mistyped .xml name, or a world file that is not there, is "no such file" even without the roads extra
    (which would otherwise be named as the thing to install)."""
    monkeypatch.setitem(sys.modules, "commonroad", None)  # as if the roads extra were not installed
    for scenario in (tmp_path / "nope.xml", _write(tmp_path, "world: {commonroad: nope.xml}\ntask: {route: true}\n")):
        with pytest.raises(SpecError, match=r"nope\.xml: no such file; check the path$"):
            load_scenario(scenario)


@settings(max_examples=60, deadline=None)
@given(st.dictionaries(st.sampled_from(["task", "vehicle", "pose", "step", "seed", "sensors", "duration", "expect",
                                        "speed_controller", "initial"]),
                       st.recursive(st.none() | st.booleans() | st.floats() | st.integers(-5, 50)
                                    | st.sampled_from(["vilma", "pi_ff", "ekf", "stanley", "x"]),
                                    lambda c: st.lists(c, max_size=3) | st.dictionaries(
                                        st.sampled_from(["speed", "go_to", "type", "kp", "gps", "rate_hz", "max"]),
                                        c, max_size=3), max_leaves=8)))
def test_random_scenarios_load_or_fail_cleanly(data):
    try:
        s = parse_scenario(data, load_yaml("", "r.yaml")[1])
    except SpecError as e:
        assert str(e).startswith("r.yaml")
        return
    assert s.task.kind in ("speed", "go_to", "follow", "course")


# -- values that would exhaust the machine: refused on their line, before anything is allocated ---------------


@pytest.mark.parametrize(("text", "message"), [
    # a day at the default 50 Hz driver (pi_ff 25 Hz, stanley 50 Hz) is 86400 / 0.02 = MAX_ROWS log rows
    ("task: {speed: 5}\nspeed_controller: pi_ff\npath_controller: stanley\nduration: 86401\n",
     f"s.yaml:4: duration: 86401 s is more than the {MAX_ROWS} driver periods of 0.02 s a run keeps"),
    ("task: {speed: 5}\nduration: 1e9\n", "s.yaml:2: duration: 1000000000 s is more than"),
    ("task: {speed: 5}\nwatchdog_timeout: 1e10\n", "s.yaml:2: watchdog_timeout: time must be finite and within"),
    ("task: {speed: 5}\nactuators: {dead_time: 1e300}\n", "s.yaml:2: actuators.dead_time: time must be finite"),
    ("task: {speed: 5}\nsensors: {gps: {rate_hz: 1e-10}}\n",
     "s.yaml:2: sensors.gps.rate_hz: sensor gps: 1e-10 Hz is a period longer than the clock counts"),
    ("task: {speed: 5}\nspeed_controller: {type: pi_ff, period: 1e300}\n",
     "s.yaml:2: speed_controller.period: pi_ff period: 1e-300 Hz is a period longer than the clock counts"),
    ("task: {speed: 5}\nstep: 1e-12\n", "s.yaml:2: step: physics step must be in [0.0001, 0.01] s, got 1e-12"),
    ("task:\n  speed: 1e300\n", "s.yaml:2: task.speed: 1e+300 m/s is faster than the car's top speed, 56.99 m/s"),
    ("task: {course: [[0, 0], [1, 0]], speed: 5, densify: 20}\n",
     f"s.yaml:1: task.densify: densify must be 0..19 (each pass doubles the points; a path holds at most "
     f"{MAX_POINTS})"),
])
def test_exhausting_values_give_one_located_line(tmp_path, text, message):
    _refused_on_one_line(tmp_path, text, message)


def test_the_longest_run_is_a_day_at_50_hz_and_the_error_says_so(tmp_path):
    day = load_scenario(_write(tmp_path, FIVE_LINES + "duration: 86400\n"))
    assert day.duration == 86400 and 86400 / day.sim.step / 2 == MAX_ROWS  # stanley's 0.02 s is two 10 ms steps
    with pytest.raises(SpecError, match=r"^--set duration=1e9: duration: .* give at most 86400 s$"):
        load_scenario(_write(tmp_path, FIVE_LINES), {"duration": "1e9"})


@pytest.mark.parametrize("vehicle", ["vilma", "bmw_320i"])
def test_speeds_above_the_cars_top_speed_are_refused(tmp_path, vehicle):
    top = preset(vehicle).top_speed
    ok = load_scenario(_write(tmp_path, f"vehicle: {vehicle}\ntask: {{speed: {0.99 * top}}}\n"
                                        f"initial: {{speed: {-0.99 * top}}}\n"))
    assert ok.task.speed == pytest.approx(0.99 * top)
    for key in ("task.speed", "initial.speed"):
        with pytest.raises(SpecError, match=rf"^--set {key}=.*: {key}: .* m/s is faster than the car's top speed"):
            load_scenario(_write(tmp_path, f"vehicle: {vehicle}\ntask: {{speed: 5}}\n"), {key: str(1.01 * top)})


def test_densify_and_resample_stop_at_the_point_limit(tmp_path):
    _write(tmp_path, "0 0\n100 0\n", "line.txt")  # two points 100 m apart
    base = "task: {follow: line.txt, speed: 5, "
    assert len(load_scenario(_write(tmp_path, base + "densify: 19}\n")).reference_path()) == 2**19 + 1
    _write(tmp_path, "0 0\n50 0\n100 0\n", "line.txt")  # three points: 2 * 2^19 + 1 is over the limit
    with pytest.raises(SpecError, match=rf"s\.yaml: task: densifying 3 points 19 times makes more than {MAX_POINTS}"):
        load_scenario(_write(tmp_path, base + "densify: 19}\n")).reference_path()
    with pytest.raises(SpecError, match=r"s\.yaml: task: resampling 100\.0 m every 1e-06 m .* at least 0\.000101 m$"):
        load_scenario(_write(tmp_path, base + "resample: 1e-6}\n")).reference_path()
    assert len(load_scenario(_write(tmp_path, base + "resample: 0.000101}\n")).reference_path()) <= MAX_POINTS


def test_other_yaml_files_have_the_same_limits(tmp_path):
    """Vehicle parameter files and Zenoh configs go through the same bounded reader as scenarios."""
    lol = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]", *(f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]"
                                                      for i in range(1, 6))]
    bomb = _write(tmp_path, "\n".join(lol), "bomb.yaml")
    with pytest.raises(SpecError, match=rf"bomb\.yaml:5: more than {MAX_YAML_VALUES} values"):
        load_scenario(_write(tmp_path, "task: {speed: 5}\nvehicle: bomb.yaml\n"))
    with pytest.raises(SpecError, match=rf"bomb\.yaml:5: more than {MAX_YAML_VALUES} values"):
        zenoh_bus(argparse.Namespace(zenoh_config=str(bomb), listen=None, connect=None), (), ())
