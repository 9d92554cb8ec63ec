import subprocess
import sys

from vilma.cli import main


def test_demo_drives_and_reports(capsys):
    assert main(["demo", "--duration", "22"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert "vilma demo drive" in lines[0]
    last = next(ln for ln in lines if ln.strip().startswith("22.0")).split()
    x, y, speed = float(last[1]), float(last[2]), float(last[4])
    # accelerates to 10 m/s, changes lane 3.5 m left, brakes: far down the road, in the new lane, nearly stopped
    assert x > 100.0 and abs(y - 3.5) < 0.1 and speed < 0.5


def test_bad_arguments_exit_2_without_traceback():
    r = subprocess.run([sys.executable, "-m", "vilma.cli", "demo", "--duration", "abc"], capture_output=True,
                       text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "--duration" in r.stderr


def test_bad_value_is_one_line_error(capsys):
    assert main(["demo", "--duration", "-1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error" in err
