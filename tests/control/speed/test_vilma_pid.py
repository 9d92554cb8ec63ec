"""The original speed controller: its rules one by one, then the paper's Figure 11 against the original logs."""

import numpy as np
import pytest

from tests.control.conftest import LOGS
from tests.control.speed.conftest import speed_run, time_to
from vilma.control.registry import controller_type
from vilma.control.speed.vilma_pid import VilmaPidParams
from vilma.vehicle.actuators import POWER
from vilma.vehicle.params import vilma


def make_pid(params: VilmaPidParams | None = None):
    """The registered ``vilma_pid``; its state is [integral of the error, last power]."""
    return controller_type("vilma_pid").make(vilma(), params)


def drive(pid, target: float, speed: float, steer: float) -> float:
    """The power of one step."""
    return pid.step(target, speed, steer)[1]


def _log(target: int) -> tuple[np.ndarray, np.ndarray]:
    data = np.loadtxt(LOGS / f"SpeedLog{target}.txt", skiprows=1, encoding="utf-8")
    return data[:, 0], data[:, 1]


def test_large_error_is_pure_p_with_rate_limit():
    pid = make_pid()
    # Kp e = 200 * 10 = 2000, but the power may rise only 10 per period; velocityAmount 100 as the original
    assert pid.step(10.0, 0.0, 0.0) == (POWER, 10.0, 0.0, 100.0)
    assert drive(pid, 10.0, 0.0, 0.0) == 20.0


def test_power_cap_scales_with_target_and_steering():
    pid = make_pid(VilmaPidParams(rise_per_period=1e9))
    assert drive(pid, 5.0, 0.0, 0.0) == 50.0 * 5.0
    pid.reset()
    assert drive(pid, 5.0, 0.0, 0.1) == pytest.approx(50.0 * 5.0 + 800.0 * 0.1)


def test_small_error_integrates_and_clamps_the_integral_term():
    pid = make_pid(VilmaPidParams(rise_per_period=1e9, fall_per_period=1e9, max_power_speed=1e9))
    out = [drive(pid, 5.0, 4.5, 0.0) for _ in range(200)]
    # P = 200 * 0.5 = 100; the integral term grows 50 * 0.25 * 0.5 per period up to 25 * 5 = 125
    assert out[0] == pytest.approx(100.0 + 50.0 * 0.25 * 0.5)
    assert out[-1] == pytest.approx(100.0 + 125.0)


def test_falls_at_most_40_per_period_and_never_negative():
    pid = make_pid(VilmaPidParams(rise_per_period=1e9))
    assert drive(pid, 10.0, 0.0, 0.0) == 500.0
    assert drive(pid, 10.0, 20.0, 0.0) == 460.0
    pid.reset()
    assert drive(pid, 0.0, 5.0, 0.0) == 0.0  # clamped at zero (the paper's intent)


def test_original_quirks():
    pid = make_pid(VilmaPidParams.original())
    pid.state[1] = 100.0
    # |e| = 1.5: C int abs gives 1, so still the PI regime (the binary's threshold is 2 m/s)
    assert drive(pid, 5.9, 3.5, 0.0) == pytest.approx(110.0)  # target truncated to 5: e = 1.5; rate limited
    assert pid.state[0] == pytest.approx(0.25 * 1.5)
    pid = make_pid(VilmaPidParams.original())
    pid.state[1] = 40.0
    assert drive(pid, 0.0, 3.0, 0.0) == 0.0  # capped at 50 * 0 first; then -(...) mirrored only if negative
    pid = make_pid(VilmaPidParams(mirror_negative=True, max_power_speed=1e9, fall_per_period=1e9))
    assert drive(pid, 0.0, 3.0, 0.0) == 600.0  # -200 * 3 mirrored


@pytest.mark.parametrize("target", [5, 10, 15])
def test_step_response_matches_the_original_logs(target):
    t_log, v_log = _log(target)
    t90_log = time_to(t_log, v_log, 0.9 * target)
    overshoot_log = v_log.max() / target - 1
    assert overshoot_log < 0.06
    t, v = speed_run(make_pid(), target, seconds=40.0, delay=True)
    assert time_to(t, v, 0.9 * target) == pytest.approx(t90_log, rel=0.25)
    assert v.max() / target - 1 < 0.06
    assert v[-1] == pytest.approx(target, abs=0.05)


def test_original_speed_formula_on_a_straight_line_is_the_speed():
    _, v = speed_run(make_pid(VilmaPidParams.original()), 10, seconds=30.0, delay=True, original_speed=True)
    assert v[-1] == pytest.approx(10.0, abs=0.1)
