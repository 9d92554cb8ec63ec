import subprocess
import sys

from vilma.cli import main


def test_demo_follows_the_course_and_stops_on_its_end(capsys):
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("vilma demo: the vilma car")
    summary = out.strip().splitlines()[-1]
    assert summary.startswith("Arrived: ")
    end_distance = float(summary.split()[1])
    assert end_distance < 1.0  # the driver stops within 1 m of the last point


def test_demo_with_the_original_controllers(capsys):
    assert main(["demo", "--speed-controller", "vilma_pid", "--path-controller", "pure_pursuit"]) == 0
    assert "Arrived" in capsys.readouterr().out


def test_bad_arguments_exit_2_without_traceback():
    r = subprocess.run([sys.executable, "-m", "vilma.cli", "demo", "--duration", "abc"], capture_output=True,
                       text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "--duration" in r.stderr


def test_bad_value_is_one_line_error(capsys):
    assert main(["demo", "--duration", "-1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error" in err
