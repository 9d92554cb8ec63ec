"""The ``vilma trajectory`` tools from the shell."""

from __future__ import annotations

import numpy as np
import pytest

from vilma.cli import main
from vilma.scenario.batch import BUNDLED
from vilma.trajectory import load_trajectory

CURVED = BUNDLED / "data" / "PositionLog_curved.txt"


def test_info_densify_smooth_resample(tmp_path, capsys):
    assert main(["trajectory", "info", str(CURVED)]) == 0
    assert f"{CURVED}: 357 points" in capsys.readouterr().out
    dense, smooth, even = tmp_path / "d.txt", tmp_path / "s.csv", tmp_path / "r.txt"
    assert main(["trajectory", "densify", str(CURVED), str(dense), "--times", "2"]) == 0
    assert len(load_trajectory(dense)) == 2 * (2 * 357 - 1) - 1  # n -> 2n - 1, twice
    assert main(["trajectory", "smooth", str(dense), str(smooth)]) == 0
    a, b = load_trajectory(dense), load_trajectory(smooth)
    assert len(b) == len(a) and np.allclose(b.xy[[0, -1]], a.xy[[0, -1]], atol=1e-6)  # ends fixed
    assert main(["trajectory", "resample", str(smooth), str(even), "--spacing", "2"]) == 0
    r = load_trajectory(even)
    # points every 2 m of arc: chords 2 R sin(1 / R) are at least 1.95 m on the tightest 3 m radius
    assert np.all((np.diff(r.s)[:-1] > 1.95) & (np.diff(r.s)[:-1] <= 2.0 + 1e-9))


@pytest.mark.parametrize(("args", "message"), [
    (["trajectory", "smooth", str(CURVED)], "give the output file"),
    (["trajectory", "smooth", str(CURVED), "out.txt", "--beta", "-1"], "beta >= 0"),
    (["trajectory", "resample", str(CURVED), "out.txt", "--spacing", "0"], "spacing must be a positive"),
    (["trajectory", "info", "missing.txt"], "missing.txt: no such file"),
])
def test_bad_input_is_one_line_and_exit_2(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "out.txt").exists()


def test_smooth_of_a_device_is_refused_unread(capsys, tmp_path):
    assert main(["trajectory", "smooth", "/dev/zero", str(tmp_path / "out.txt")]) == 2  # reading it would never end
    assert capsys.readouterr().err == ("vilma trajectory: error: /dev/zero: not a regular file (a folder, device or "
                                       "pipe); give a trajectory file\n")
    assert not (tmp_path / "out.txt").exists()


def test_drive_data_dir_must_be_a_folder(capsys, tmp_path):
    with pytest.raises(SystemExit) as e:
        main(["drive", "--data-dir", str(tmp_path / "nope")])
    assert e.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == (f"vilma drive: error: argument --data-dir: "
                                                        f"'{tmp_path / 'nope'}' is not a folder; create it or give "
                                                        "another")
