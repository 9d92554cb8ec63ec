import numpy as np
import pytest

from tests.control.conftest import LOGS
from vilma.trajectory import SpeedRecorder, TrajectoryRecorder, load_speed_log, load_trajectory
from vilma.trajectory.recorder import SPEED_LOG_HEADER


def test_position_log_every_250_ms_of_sim_time(tmp_path):
    f = tmp_path / "PositionLog.txt"
    with TrajectoryRecorder(f) as rec:
        for k in range(101):  # 1 s at 100 Hz
            rec.add(k * 10_000_000, k * 0.1, 1.0)
    t = load_trajectory(f)
    # one line at once, then at 0.25, 0.5, 0.75, 1.0 s
    assert np.allclose(t.xy[:, 0], [0.0, 2.5, 5.0, 7.5, 10.0])


def test_speed_log_format_and_original_logs(tmp_path):
    f = tmp_path / "SpeedLog.txt"
    with SpeedRecorder(f) as rec:
        for k in range(60):
            rec.add(5_000_000_000 + k * 20_000_000, 3.0)
    assert f.read_text(encoding="utf-8").splitlines()[0] == SPEED_LOG_HEADER
    t, v = load_speed_log(f)
    # samples come every 20 ms: each line is the first sample at or after its 250 ms mark
    assert np.allclose(t, [0.0, 0.26, 0.5, 0.76, 1.0]) and np.all(v == 3.0)
    for target in (5, 10, 15):
        t, v = load_speed_log(LOGS / f"SpeedLog{target}.txt")
        assert np.median(np.diff(t)) == pytest.approx(0.26, abs=0.02) and v[-1] == pytest.approx(target, abs=0.1)


def test_bad_period():
    with pytest.raises(ValueError):
        TrajectoryRecorder("x", period=0)


@pytest.mark.parametrize(("body", "error"), [
    ("", "SpeedLog.txt: no samples"),
    ("0.0\t1.0\n\n0.25\t2.0 3.0\n", "SpeedLog.txt:4: 3 values"),
    ("0.0\tfast\n", "SpeedLog.txt:2: value 'fast' is not a number"),
    ("0.0\tnan\n", "SpeedLog.txt:2: value 'nan' is not finite"),
])
def test_a_speed_log_that_is_not_a_time_and_a_speed_a_line_is_refused_with_its_line(tmp_path, body, error):
    f = tmp_path / "SpeedLog.txt"
    f.write_text(SPEED_LOG_HEADER + "\n" + body, encoding="utf-8")
    with pytest.raises(ValueError, match=error):
        load_speed_log(f)
