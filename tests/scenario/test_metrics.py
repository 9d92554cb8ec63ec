"""The scorecard on drives whose figures follow from kinematics (not from a run of vilma)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vilma.scenario.drive_log import COLUMNS, DriveLog
from vilma.scenario.metrics import check_expectations, scorecard, step_response
from vilma.scenario.spec import SCORECARD_KEYS, Bound, Scenario, TaskSpec
from vilma.trajectory import Trajectory

DT = 0.02


def _log(t, **cols) -> DriveLog:
    log = DriveLog(capacity=8)  # small: the buffer grows
    rows = np.zeros((len(t), len(COLUMNS)))
    rows[:, 0] = t
    for name, values in cols.items():
        rows[:, COLUMNS.index(name)] = values
    for r in rows:
        log.add(r)
    return log


def test_first_order_speed_step():
    """v = V (1 - exp(-t / tau)): t90 = tau ln 10, no overshoot, 2 % settling at tau ln 50."""
    tau, target = 3.0, 10.0
    t = np.arange(0, 40, DT)
    v = target * (1 - np.exp(-t / tau))
    s = step_response(t, v, target, 0.02, 5.0)
    assert s["speed_rise_time_90_s"] == pytest.approx(tau * math.log(10), abs=1e-3)
    assert s["speed_overshoot_pct"] == 0.0
    assert s["speed_settling_time_2pct_s"] == pytest.approx(tau * math.log(50), abs=DT)
    assert s["speed_steady_state_error_mps"] == pytest.approx(0.0, abs=1e-4)


def test_overshoot_and_a_speed_that_never_settles():
    t = np.arange(0, 20, DT)
    v = 10.0 + 1.0 * np.sin(t)  # +-10 % forever
    s = step_response(t, v, 10.0, 0.02, 5.0)
    assert s["speed_overshoot_pct"] == pytest.approx(10.0, abs=0.01)
    assert "speed_settling_time_2pct_s" not in s  # never settles: the scorecard says null


def test_straight_path_with_a_constant_offset_and_a_circle():
    """Driving 0.3 m left of a straight line: lateral RMS = max = p95 = 0.3, heading error 0."""
    t = np.arange(0, 10, DT)
    x = 5.0 * t
    log = _log(t, x=x, y=np.full_like(t, 0.3), vx=np.full_like(t, 5.0), target_speed=np.full_like(t, 5.0))
    path = Trajectory.from_points([(-10, 0), (100, 0)])
    scenario = Scenario(name="s", task=TaskSpec(course=((0, 0), (1, 0)), speed=5.0))
    m = scorecard(log, scenario, path, 0.0, True, 0.5)
    assert set(m) == set(SCORECARD_KEYS)
    assert m["lateral_error_rms_m"] == pytest.approx(0.3)
    assert m["lateral_error_max_m"] == pytest.approx(0.3) and m["lateral_error_p95_m"] == pytest.approx(0.3)
    assert m["heading_error_rms_rad"] == pytest.approx(0.0)
    assert m["distance_m"] == pytest.approx(5.0 * t[-1])
    assert m["realtime_factor"] == pytest.approx(t[-1] / 0.5)
    assert m["speed_error_rms_mps"] == pytest.approx(0.0)
    assert m["longitudinal_jerk_rms_mps3"] == pytest.approx(0.0, abs=1e-9)
    assert m["speed_rise_time_90_s"] is None  # not a speed step
    assert m["pose_error_rms_m"] is None  # exact pose


def test_circle_lateral_acceleration_is_v2_over_r():
    v, r = 8.0, 20.0
    t = np.arange(0, 10, DT)
    yaw = v / r * t
    log = _log(t, x=r * np.sin(yaw), y=r * (1 - np.cos(yaw)), yaw=yaw, vx=np.full_like(t, v),
               steer=np.full_like(t, 0.1))
    m = scorecard(log, Scenario(name="c", task=TaskSpec(speed=v)), None, 0.0, True, 1.0)
    assert m["lateral_accel_max_mps2"] == pytest.approx(v * v / r, rel=1e-3)
    assert m["steering_rate_rms_radps"] == pytest.approx(0.0)
    assert m["lateral_error_rms_m"] is None  # no path


def test_expectations():
    m = {"completed": True, "lateral_error_rms_m": 0.2, "pose_error_rms_m": None}
    assert check_expectations(m, {"completed": True, "lateral_error_rms_m": Bound(max=0.3)}) == []
    fails = check_expectations(m, {"completed": False, "lateral_error_rms_m": Bound(min=0.25, max=0.3),
                                   "pose_error_rms_m": Bound(max=1.0)})
    assert fails == ["completed: expected false, got True", "lateral_error_rms_m: 0.2 is outside min 0.25 and max 0.3",
                     "pose_error_rms_m: None is outside max 1"]
