import math
import os
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.control.conftest import LOGS
from vilma.core.geodesy import GeodeticOrigin
from vilma.trajectory import Trajectory, TrajectoryFileError, load_trajectory, save_trajectory
from vilma.trajectory.io import MAX_FILE_BYTES


def test_pairs_split_anyhow_read_as_the_original_read_them(tmp_path):
    f = tmp_path / "PositionLog.txt"
    f.write_text("0 0 10\n0 20 0\n\n30 5\n")  # X, Y, X, Y ... across lines, as its Input From File took them
    assert np.array_equal(load_trajectory(f).xy, [(0, 0), (10, 0), (20, 0), (30, 5)])


def test_loads_the_original_logs():
    t = load_trajectory(LOGS / "PositionLog_curved.txt")
    assert len(t) == 357 and t.length == pytest.approx(169, abs=2)  # "357 points over about 169 m"
    s = load_trajectory(LOGS / "PositionLog_straight.txt")
    assert s.xy[0] == pytest.approx((-0.351981, 16.786390))


@pytest.mark.parametrize(("text", "line", "what"), [
    ("1 2\n3 4\n5\n", 3, "odd count"),
    ("1 2\n3 x4\n", 2, "'x4' is not a number"),
    ("", None, "no points"),
    ("1 2\nnan 3\n", 2, "not finite"),
    ("0 0 5\n10 0 5\n20 0 5\n30 0 5\n", None, "3 numbers on every line; this format holds x y pairs"),  # not 6 points
])
def test_bad_original_files_name_file_and_line(tmp_path, text, line, what):
    f = tmp_path / "PositionLog.txt"
    f.write_text(text)
    with pytest.raises(TrajectoryFileError) as e:
        load_trajectory(f)
    msg = str(e.value)
    assert msg.startswith(f"{f}:{line}:" if line else f"{f}:") and what in msg and "\n" not in msg


def test_csv_with_speed_and_errors(tmp_path):
    f = tmp_path / "t.csv"
    f.write_text("speed,x,y\n5,0,0\n6,10,0\n")
    t = load_trajectory(f)
    assert np.array_equal(t.xy, [(0, 0), (10, 0)]) and np.array_equal(t.speed, [5, 6])
    f.write_text("x,y,z\n0,0,0\n")
    with pytest.raises(TrajectoryFileError, match=r"t.csv:1: .*unknown: \['z'\]"):
        load_trajectory(f)
    f.write_text("x,y\n0,0\n1\n")
    with pytest.raises(TrajectoryFileError, match=r"t\.csv:3: 1 fields"):
        load_trajectory(f)


def test_gpx_to_local_enu(tmp_path):
    f = tmp_path / "t.gpx"
    f.write_text('<?xml version="1.0"?><gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1"><trk><trkseg>'
                 '<trkpt lat="-22.8195" lon="-47.0663"/><trkpt lat="-22.8186" lon="-47.0663"/></trkseg></trk></gpx>')
    t = load_trajectory(f, origin=GeodeticOrigin())
    # 0.0009 deg of latitude north is about 99.7 m at 22.8 deg south
    assert t.xy[0] == pytest.approx((0, 0), abs=1e-6)
    assert t.xy[1, 0] == pytest.approx(0, abs=1e-3) and t.xy[1, 1] == pytest.approx(99.7, abs=0.2)
    f.write_text("<gpx><trk>")
    with pytest.raises(TrajectoryFileError, match="malformed GPX"):
        load_trajectory(f)


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(TrajectoryFileError, match="no such file"):
        load_trajectory(tmp_path / "nope.txt")
    f = tmp_path / "b.txt"
    f.write_bytes(b"1 2\n\xff\xfe")
    with pytest.raises(TrajectoryFileError, match=r"b\.txt:2: not UTF-8"):
        load_trajectory(f)


def test_devices_pipes_folders_and_large_files_are_refused_unread(tmp_path):
    os.mkfifo(tmp_path / "pipe")  # opening it would wait for a writer
    big = tmp_path / "big.txt"
    with open(big, "wb") as f:  # sparse: takes no disk
        f.truncate(MAX_FILE_BYTES + 1)
    link = tmp_path / "zero.txt"
    link.symlink_to("/dev/zero")  # reading it would never end
    cases = [(p, "not a regular file (a folder, device or pipe); give a trajectory file")
             for p in (tmp_path / "pipe", tmp_path, link, "/dev/zero")]
    cases.append((big, f"{MAX_FILE_BYTES + 1} bytes, over the {MAX_FILE_BYTES >> 20} MiB a trajectory file "
                       "may hold; keep fewer points (every n-th line)"))
    for path, what in cases:
        tracemalloc.start()
        try:
            with pytest.raises(TrajectoryFileError) as e:
                load_trajectory(path)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert str(e.value) == f"{path}: {what}" and peak < MAX_FILE_BYTES


def test_a_file_at_the_cap_is_read(tmp_path):
    f = tmp_path / "full.txt"
    points = b"0 0\n3 4\n"
    f.write_bytes(points + b" " * (MAX_FILE_BYTES - len(points)))
    assert load_trajectory(f).length == 5.0


@pytest.mark.parametrize("name", ["p.txt", "p.csv"])
def test_save_round_trip(tmp_path, name):
    t = Trajectory.from_points([(0.1234567, -2.5), (3.0, 4.0)], speed=[1.0, 2.0] if name.endswith("csv") else None)
    save_trajectory(tmp_path / name, t)
    back = load_trajectory(tmp_path / name)
    assert np.allclose(back.xy, t.xy, atol=1e-6)


def test_failed_save_keeps_the_old_file(tmp_path, full_disk):
    f = tmp_path / "p.txt"
    f.write_text("1 2\n")
    with pytest.raises(TrajectoryFileError, match="untouched"):
        save_trajectory(f, Trajectory.from_points([(5, 6)]))
    assert f.read_text() == "1 2\n" and os.listdir(tmp_path) == ["p.txt"]


@settings(suppress_health_check=[HealthCheck.function_scoped_fixture], max_examples=150)
@given(data=st.binary(max_size=200), suffix=st.sampled_from([".txt", ".csv", ".gpx"]))
def test_random_bytes_load_cleanly_or_fail_clearly(tmp_path, data, suffix):
    f = tmp_path / f"r{suffix}"
    f.write_bytes(data)
    try:
        t = load_trajectory(f)
    except TrajectoryFileError as e:
        assert str(e).startswith(str(f)) and "\n" not in str(e)
    else:
        assert np.isfinite(t.xy).all()


numeric = st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.integers().map(str),
                             st.sampled_from(["x", "-", "1e999", "0x10", "", "1,5"])), max_size=12)


@settings(suppress_health_check=[HealthCheck.function_scoped_fixture], max_examples=150)
@given(tokens=numeric, seps=st.lists(st.sampled_from([" ", "\t", "\n", "  "]), min_size=12, max_size=12))
def test_random_numeric_text(tmp_path, tokens, seps):
    f = tmp_path / "n.txt"
    f.write_text("".join(t + s for t, s in zip(tokens, seps, strict=False)))
    try:
        t = load_trajectory(f)
    except TrajectoryFileError:
        return
    values = [float(x) for x in " ".join(tokens).split()]
    assert all(math.isfinite(v) for v in values) and len(values) == 2 * len(t)


def test_a_saved_trajectory_has_the_mode_the_umask_gives(tmp_path):
    f = tmp_path / "p.txt"
    f.write_text("1 2\n")
    f.chmod(0o644)
    old = os.umask(0o022)
    try:
        save_trajectory(f, Trajectory.from_points([(5, 6), (7, 8)]))
    finally:
        os.umask(old)
    assert f.stat().st_mode & 0o777 == 0o644  # not mkstemp's 0600
