"""The core without its extras: the main job runs; a part that needs a missing extra says which, in one line."""

from __future__ import annotations

import subprocess
import sys

import pytest

from vilma.core.extras import EXTRAS, MissingExtraError, require

WITHOUT_EXTRAS = ("import sys\n"
                  f"for m in {[m for ms in EXTRAS.values() for m in ms]!r}:\n"
                  "    sys.modules[m] = None  # as if not installed: importing it raises ImportError\n"
                  "from vilma.app.cli import main\n"
                  "sys.exit(main(sys.argv[1:]))\n")


def _vilma_without_extras(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", WITHOUT_EXTRAS, *args], capture_output=True, text=True,
                          timeout=240)


def test_a_missing_extra_names_itself():
    assert require("3d", "the 3D plant") is None  # installed here
    sys.modules["mujoco"], saved = None, sys.modules.get("mujoco")
    try:
        with pytest.raises(MissingExtraError, match=r"^the 3D plant needs the '3d' extra \(mujoco is not installed\): "
                                                r"pip install 'vilma\[3d\]'$"):
            require("3d", "the 3D plant")
    finally:
        if saved is None:
            del sys.modules["mujoco"]
        else:
            sys.modules["mujoco"] = saved


@pytest.mark.slow
def test_the_core_runs_a_scenario_without_the_extras(tmp_path):
    (tmp_path / "s.yaml").write_text("task: {course: [[0, 0], [30, 0]], speed: 5}\n")
    r = _vilma_without_extras("run", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "o"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "o" / "metrics.json").exists() and (tmp_path / "o" / "run.mcap").exists()


@pytest.mark.parametrize(("args", "line"), [
    (["run", "course_3d_obstacles", "--no-record"], "vilma run: error: the 3D plant (plant: mujoco) needs the '3d' "
                                                    "extra (mujoco is not installed): pip install 'vilma[3d]'"),
    (["gui"], "vilma gui: error: vilma gui needs the 'gui' extra (PySide6 is not installed): "
              "pip install 'vilma[gui]'"),
    (["run", "pi_ff_speed_5", "--foxglove", "--realtime", "1", "--no-record"],
     "vilma run: error: the live Foxglove view needs the 'foxglove' extra (foxglove is not installed): "
     "pip install 'vilma[foxglove]'"),
    (["tune", "t.yaml"], "vilma tune: error: vilma tune needs the 'sweep' extra (distributed is not installed): "
                         "pip install 'vilma[sweep]'"),
])
def test_a_command_that_needs_a_missing_extra_says_which_in_one_line(args, line, tmp_path):
    r = _vilma_without_extras(*args, *(["--out", str(tmp_path / "o")] if args[0] == "run" else []))
    assert r.returncode == 2 and r.stderr.splitlines()[-1] == line and "Traceback" not in r.stderr


@pytest.mark.parametrize("command", ["up", "sim"])
def test_a_program_asked_for_foxglove_without_its_extra_starts_nothing(command):
    r = _vilma_without_extras(command, "--foxglove", "--duration", "1", *(["--no-morse"] if command == "sim" else []))
    assert r.returncode == 2 and r.stdout == ""  # (nothing said nor started before the refusal)
    assert r.stderr == (f"vilma {command}: error: the live Foxglove view needs the 'foxglove' extra (foxglove is not "
                        "installed): pip install 'vilma[foxglove]'\n")
