"""The ``vilma`` command from the shell: the trajectory tools, option values and hostile scenarios."""

from __future__ import annotations

import ctypes
import json
import logging
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from vilma.app.arguments import COMMANDS, parser
from vilma.app.cli import HANDLERS, main
from vilma.morse import COMPONENTS
from vilma.scenario.bundled import BUNDLED, names, summary
from vilma.scenario.fields import MAX_YAML_DEPTH, MAX_YAML_VALUES
from vilma.trajectory import load_trajectory
from vilma.trajectory.points import MAX_POINTS

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


def test_smoothing_weights_the_sweeps_cannot_converge_with_are_one_line_and_exit_2(tmp_path, capsys):
    out = tmp_path / "o.csv"
    assert main(["trajectory", "smooth", str(CURVED), str(out), "--beta", "1"]) == 2
    assert capsys.readouterr().err == ("vilma trajectory: error: beta must be in [0, 0.75) with alpha 0.5 for the "
                                       "iterative sweeps to converge (alpha + 2 beta < 2), got 1; lower it, or solve "
                                       "directly: solver banded (--solver banded)\n")
    assert not out.exists()
    assert main(["trajectory", "smooth", str(CURVED), str(out), "--beta", "1", "--solver", "banded"]) == 0
    assert np.isfinite(load_trajectory(out).xy).all()


@pytest.mark.parametrize(("args", "message"), [
    (["trajectory", "smooth", str(CURVED)], "give the output file"),
    (["trajectory", "info", "missing.txt"], "missing.txt: no such file"),
    # 357 points: (357 - 1) 2^12 + 1 > 1e6 points; 168.8 m at 1e-12 m is 1.7e14 points
    (["trajectory", "densify", str(CURVED), "out.txt", "--times", "12"],
     f"densifying 357 points 12 times makes more than {MAX_POINTS} points, the limit of a path; densify fewer times"),
    (["trajectory", "densify", str(CURVED), "out.txt", "--times", "1000000000"], "357 points 1000000000 times"),
    (["trajectory", "resample", str(CURVED), "out.txt", "--spacing", "1e-12"],
     f"resampling 168.8 m every 1e-12 m makes more than {MAX_POINTS} points, the limit of a path; use a spacing of "
     "at least 0.000169 m"),
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


@pytest.mark.parametrize(("args", "option", "message"), [
    (["run", "x.yaml", "--foxglove", "99999"], "--foxglove", "must be a TCP port, 1-65535, got 99999"),
    (["sim", "--foxglove", "0"], "--foxglove", "must be a TCP port, 1-65535, got 0"),
    (["up", "--foxglove", "http"], "--foxglove", "expected a whole number, got 'http'"),
    (["sim", "--morse-port", "65536"], "--morse-port", "must be a TCP port, 1-65535, or 0 for any free port"),
    (["sim", "--morse-stream-port", "-1"], "--morse-stream-port", f"must be a TCP port, 1-{65536 - len(COMPONENTS)} "
     f"(the {len(COMPONENTS)} datastreams take consecutive ports from it), or 0 for any free ports, got -1"),
    (["sim", "--morse-stream-port", "65535"], "--morse-stream-port",
     f"must be a TCP port, 1-{65536 - len(COMPONENTS)}"),
    (["sim", "--morse-host", "999.1.1.1"], "--morse-host", "'999.1.1.1' is not an IP address; give one of this "
     "machine, e.g. 127.0.0.1 (0.0.0.0 or :: for all its interfaces)"),
    (["sim", "--duration", "nan"], "--duration", "must be a number of seconds > 0 (inf: no end), got nan"),
    (["up", "--duration", "0"], "--duration", "must be a number of seconds > 0"),
    (["ros1-bridge", "--duration", "-5"], "--duration", "must be a number of seconds > 0"),
    (["sim", "--speed", "0"], "--speed", "must be a finite number > 0, got 0"),
    (["up", "--speed", "inf"], "--speed", "must be a finite number > 0, got inf"),
    (["gui", "--speed", "nan"], "--speed", "must be a finite number > 0, got nan"),
    (["replay", "r.mcap", "--speed", "-2"], "--speed", "must be a finite number > 0, got -2"),
    (["run", "x.yaml", "--realtime", "-1"], "--realtime", "must be a finite number > 0, got -1"),
    (["demo", "--realtime", "nan"], "--realtime", "must be a finite number > 0, got nan"),
    (["gui", "--refresh", "0"], "--refresh", "must be a whole number >= 1, got 0"),
    (["gui", "--quit-after", "nan"], "--quit-after", "must be a number of seconds in (0, 2147483.647]"),
    (["gui", "--quit-after", "1e9"], "--quit-after", "must be a number of seconds in (0, 2147483.647]"),  # 24 days
    (["replay", "r.mcap", "--start", "-1"], "--start", "must be a number of seconds in [0, 9.22e+09)"),
    (["replay", "r.mcap", "--start", "1e300"], "--start", "must be a number of seconds in [0, 9.22e+09)"),
    (["trajectory", "densify", "in", "out", "--times", "0"], "--times", "must be a whole number >= 1, got 0"),
    (["trajectory", "densify", "in", "out", "--times", "1e9"], "--times", "expected a whole number, got '1e9'"),
    (["trajectory", "resample", "in", "out", "--spacing", "0"], "--spacing", "must be a finite number > 0, got 0"),
    (["trajectory", "smooth", "in", "out", "--alpha", "nan"], "--alpha", "must be a finite number > 0, got nan"),
    (["trajectory", "smooth", "in", "out", "--beta", "-1"], "--beta", "must be a finite number >= 0, got -1"),
    (["trajectory", "smooth", "in", "out", "--tolerance", "0"], "--tolerance", "must be a finite number > 0"),
    (["drive", "--connect", "tcp/127.0.0.1:abc"], "--connect", "'tcp/127.0.0.1:abc': the port must be a whole number"),
    (["drive", "--connect", "tcp/127.0.0.1:99999"], "--connect", "'tcp/127.0.0.1:99999': the port must be a whole"),
    (["sim", "--connect", "tcp/127.0.0.1:0"], "--connect", "'tcp/127.0.0.1:0': the port must be a whole number"),
    (["sim", "--listen", "garbage"], "--listen", "'garbage': not an endpoint: give <protocol>/<address>"),
    (["gui", "--connect", "garbage"], "--connect", "'garbage': not an endpoint: give <protocol>/<address>"),
    (["replay", "r.mcap", "--listen", "tcp/127.0.0.1:65536"], "--listen", "'tcp/127.0.0.1:65536': the port must"),
    (["ros1-bridge", "--connect", "tcp/127.0.0.1"], "--connect", "'tcp/127.0.0.1': no port"),
    (["gui", "--record-dir", "/nonexistent"], "--record-dir", "'/nonexistent' is not a folder; create it or give"),
])
def test_bad_option_values_are_argparse_errors(args, option, message, capsys):
    with pytest.raises(SystemExit) as e:
        main(args)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: vilma ") and "Traceback" not in err
    assert err.splitlines()[-1].startswith(f"vilma {args[0]}: error: argument {option}: {message}")


@pytest.mark.parametrize("option", [["--listen", "tcp/127.0.0.1:0"], ["--zenoh-config", "z.yaml"]])
def test_gui_options_for_zenoh_need_connect(option, capsys):
    assert main(["gui", *option]) == 2
    assert capsys.readouterr().err == (f"vilma gui: error: {option[0]} is for joining programs on Zenoh: give "
                                       "--connect ENDPOINT too (the embedded simulator needs no Zenoh)\n")


def test_a_zenoh_config_file_given_by_mistake_is_not_shown(tmp_path, capsys):
    file = tmp_path / "passwd"
    file.write_text("root:hunter2:0:0:root:/root:/bin/bash\n")
    assert main(["sim", "--zenoh-config", str(file)]) == 2
    assert capsys.readouterr().err == (f"vilma sim: error: {file}: not a Zenoh configuration: expected a mapping of "
                                       "listen, connect, multicast_scouting, extra\n")


def test_hostile_scenarios_exit_2_with_one_line(tmp_path, capsys):
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text("\n".join(['a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]',
                               *(f"a{i}: &a{i} [{','.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9))]))
    deep = tmp_path / "deep.yaml"
    deep.write_text("task: " + "[" * 5000 + "]" * 5000 + "\n")
    fast = tmp_path / "fast.yaml"
    fast.write_text("task: {speed: 1e300}\n")
    for args, message in ((["run", str(bomb)], f"{bomb}:6: more than {MAX_YAML_VALUES} values"),
                          (["run", str(deep)], f"{deep}:1: nested more than {MAX_YAML_DEPTH} levels deep"),
                          (["run", str(fast)], f"{fast}:1: task.speed: 1e+300 m/s is faster than the car's top"),
                          (["run", "pi_ff_speed_5", "--set", "duration=1e9"],
                           "--set duration=1e9: duration: 1000000000 s is more than")):
        assert main([*args, "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"vilma run: error: {message}") and err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_scenarios_lists_each_bundled_one_on_a_line(capsys):
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines == [f"{n}: {summary(BUNDLED / f'{n}.yaml')}" for n in names()]
    assert len(lines) == len(list(BUNDLED.glob("*.yaml")))


def test_run_help_names_the_bundled_scenarios(capsys):
    with pytest.raises(SystemExit) as e:
        main(["run", "--help"])
    assert e.value.code == 0
    text = " ".join(capsys.readouterr().out.split())  # argparse wraps the list
    assert all(f" {n}," in text or text.endswith(f" {n}") for n in names())


def test_the_help_and_a_mistyped_command_list_every_subcommand(capsys):
    """A command line's parser holds its own subcommand only; these two need them all."""
    for line, status in ((["--help"], 0), (["rn", "course_30kmh_stanley"], 2), (["-q", "run"], 2)):
        with pytest.raises(SystemExit) as e:
            main(line)
        assert e.value.code == status
        text = "".join(capsys.readouterr())
        assert all(name in text for name in COMMANDS), line


def test_every_subcommand_has_its_arguments_and_its_handler():
    """The parser's subcommands (``arguments.COMMANDS``) and what runs them (``cli.HANDLERS``) name the same ones."""
    assert set(HANDLERS) == set(COMMANDS)


def test_every_command_takes_verbose_and_quiet():
    commands = parser()._subparsers._group_actions[0].choices
    assert {"demo", "run", "sim", "drive", "up", "gui", "report", "trajectory", "scenarios"} <= set(commands)
    for name, sub in commands.items():
        assert {"-v", "--verbose", "-q", "--quiet"} <= {s for a in sub._actions for s in a.option_strings}, name


@pytest.mark.parametrize(("flags", "level"), [([], logging.WARNING), (["-v"], logging.INFO), (["-vv"], logging.DEBUG),
                                              (["-v", "--verbose", "-v"], logging.DEBUG), (["-q"], logging.ERROR),
                                              (["--quiet"], logging.ERROR)])
def test_verbose_and_quiet_set_the_log_level(flags, level, capsys):
    assert main(["scenarios", *flags]) == 0
    assert logging.getLogger().getEffectiveLevel() == level


def test_verbose_and_quiet_together_are_refused(capsys):
    with pytest.raises(SystemExit) as e:
        main(["scenarios", "-q", "-v"])
    assert e.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == ("vilma scenarios: error: argument -v/--verbose: not allowed "
                                                        "with argument -q/--quiet")


def test_quiet_run_prints_only_what_failed(tmp_path, capsys):
    p = tmp_path / "strict.yaml"
    # 10 m/s in 5 s: no
    p.write_text("task: {speed: 10}\nduration: 5\nexpect: {completed: false, speed_rise_time_90_s: {max: 1.0}}\n")
    assert main(["run", str(p), "--out", str(tmp_path / "o"), "-q"]) == 1
    out, err = capsys.readouterr()
    assert out == ""
    assert err == "FAIL strict: speed_rise_time_90_s: None is outside max 1\n"


def test_without_a_terminal_a_batch_prints_a_line_a_run(tmp_path, capsys):
    assert not sys.stdout.isatty()  # pytest captures it
    main(["run", "pi_ff_speed_5", "--set", "duration=1,2", "--out", str(tmp_path), "--no-record"])
    lines = capsys.readouterr().out.splitlines()
    done = [line for line in lines if re.fullmatch(r"\[\d/2\] .*: (pass|FAIL) in \d+\.\d s", line)]
    assert [line.split(":")[0] for line in done] == ["[1/2] pi_ff_speed_5 duration=1", "[2/2] pi_ff_speed_5 duration=2"]


def test_quiet_up_prints_nothing(capsys):
    assert main(["up", "pi_ff_speed_5", "--duration", "1", "--speed", "50", "-q"]) == 0
    assert capsys.readouterr() == ("", "")


def test_the_help_imports_neither_numba_nor_scipy_nor_matplotlib():
    """``vilma --help`` lists every subcommand without the heavy libraries (each costs 0.2-1 s)."""
    code = ("import sys; from vilma.app.cli import main; import contextlib, io\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try: main(['--help'])\n"
            "    except SystemExit: pass\n"
            "print(sorted(m for m in ('numba', 'scipy', 'matplotlib', 'numpy', 'distributed', 'pandas', 'pyarrow') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_a_run_imports_neither_scipy_linalg_nor_matplotlib_nor_rich_when_quiet(tmp_path):
    """numba's BLAS probe is skipped (:mod:`vilma.core.numba_start`), and no kernel of a course run needs BLAS (the
    second run: the first builds the course's spline with scipy.interpolate, which imports scipy.linalg); plots are
    drawn on request only (``--plots``), so a run without it leaves matplotlib unimported and draws no PNG; a quiet
    run that passes draws neither table nor bar, so it leaves rich unimported."""
    code = ("import sys; from vilma.app.cli import main\n"
            f"code = main(['run', 'course_30kmh_stanley', '--out', {str(tmp_path)!r}, '--overwrite', '-q'])\n"
            "print(code, *(m in sys.modules for m in ('scipy.linalg', 'matplotlib', 'rich')))")
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
            for _ in range(2)]
    assert runs[1].split() == ["0", "False", "False", "False"]
    assert not list(tmp_path.glob("*.png")) and (tmp_path / "run.mcap").exists()


def test_cars_refuse_plots_they_would_not_draw(tmp_path, capsys):
    assert main(["run", "pi_ff_speed_5", "--cars", "2", "--plots", "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.splitlines()[-1].endswith("--cars writes each car's files without plots or "
                                                              "run.mcap: drop --plots")
    assert not (tmp_path / "o").exists()


def test_the_command_ends_with_its_status_after_the_exit_handlers(tmp_path):
    """:func:`~vilma.app.cli.entry` skips the interpreter's teardown after a run: the run's status (1: an expectation
    failed), its whole output through a pipe, its files, and the exit handlers run last."""
    p = tmp_path / "strict.yaml"
    # 10 m/s in 2 s: no
    p.write_text("task: {speed: 10}\nduration: 2\nexpect: {completed: false, speed_rise_time_90_s: {max: 1.0}}\n")
    code = ("import atexit, sys; atexit.register(print, 'the exit handlers ran')\n"
            f"sys.argv = ['vilma', 'run', {str(p)!r}, '--out', {str(tmp_path / 'o')!r}]\n"
            "from vilma.app.cli import entry; entry()")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, "VILMA_SERVE": "off"})
    assert done.returncode == 1, done.stderr
    assert "files in" in done.stdout and done.stdout.splitlines()[-1] == "the exit handlers ran"
    assert json.loads((tmp_path / "o" / "metrics.json").read_text())["sim_time_s"] == pytest.approx(2.0)


def test_a_scenario_name_never_writes_outside_out(tmp_path):
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "metrics.json").write_text("mine")
    p = tmp_path / "n.yaml"
    p.write_text(f"name: {victim}\ntask: {{speed: 5}}\ninitial: {{speed: 5}}\n")
    out = tmp_path / "out"
    assert main(["run", str(p), "--set", "duration=0.5,1", "--out", str(out), "-q", "--no-record", "--overwrite"]) == 0
    assert (victim / "metrics.json").read_text() == "mine"
    runs = sorted(d.name for d in out.iterdir() if (d / "metrics.json").is_file())
    assert [n.rpartition("_victim-")[2] for n in runs] == ["duration_0.5", "duration_1"]


def test_a_batch_and_the_demo_refuse_a_folder_that_holds_anything(tmp_path, capsys):
    out = tmp_path / "b"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    p = tmp_path / "s.yaml"
    p.write_text("task: {speed: 5}\ninitial: {speed: 5}\n")  # (at its speed from the start: a whole task)
    batch = ["run", str(p), "--set", "duration=0.5,1", "--out", str(out), "-q", "--no-record"]
    for args in (batch, ["demo", "--out", str(out), "-q"]):
        assert main(args) == 2
        assert capsys.readouterr().err == (f"vilma {args[0]}: error: {out}: holds an earlier run or other files "
                                           "(notes.txt); give --overwrite to replace the run's files, or choose "
                                           "another --out\n")
        assert [p.name for p in out.iterdir()] == ["notes.txt"]
    assert main([*batch, "--overwrite"]) == 0
    assert main([*batch, "--overwrite"]) == 0  # again: each run's folder cleared of the earlier run's files
    runs = [d for d in out.iterdir() if d.is_dir()]
    assert (out / "notes.txt").read_text() == "mine" and len(runs) == 2
    assert all(sorted(p.name for p in d.iterdir()) == ["metrics.json", "scenario.yaml", "timeseries.csv"]
               for d in runs)


def test_an_interrupted_batch_with_overwrite_keeps_the_earlier_runs_it_did_not_reach(tmp_path, monkeypatch):
    """--overwrite clears each run's folder as the run starts: Ctrl-C in the first run of a batch leaves the second's
    earlier files as they were."""
    from vilma.app import batch

    out = tmp_path / "b"
    (tmp_path / "s.yaml").write_text("task: {speed: 5}\ninitial: {speed: 5}\n")
    argv = ["run", str(tmp_path / "s.yaml"), "--set", "duration=0.5,1", "--out", str(out), "-q", "--no-record"]
    assert main(argv) == 0
    first, second = (out / f"s-duration_{d}" for d in ("0.5", "1"))
    earlier = {f.name: f.read_bytes() for f in second.iterdir()}
    record_run = batch.record_run

    def interrupted_after_it_began(scenario, out_dir, **kw):
        record_run(scenario, out_dir, **kw)
        raise KeyboardInterrupt

    monkeypatch.setattr(batch, "record_run", interrupted_after_it_began)
    assert main([*argv, "--overwrite"]) == 130
    assert {f.name: f.read_bytes() for f in second.iterdir()} == earlier and (first / "metrics.json").exists()


def test_an_out_that_cannot_be_made_is_one_line_before_the_run(tmp_path, capsys):
    (tmp_path / "afile").write_text("")
    assert main(["run", "pi_ff_speed_5", "--out", str(tmp_path / "afile" / "sub")]) == 2
    assert capsys.readouterr().err == (f"vilma run: error: {tmp_path / 'afile' / 'sub'}: {tmp_path / 'afile'} is a "
                                       "file, not a folder; choose another --out\n")
    for command in (["run", "pi_ff_speed_5"], ["demo"], ["report", "run.mcap"]):
        with pytest.raises(SystemExit) as e:
            main([*command, "--out", ""])
        assert e.value.code == 2
        assert capsys.readouterr().err.splitlines()[-1] == (f"vilma {command[0]}: error: argument --out: empty; give "
                                                            "a folder, or no --out for the default")


def test_a_trajectory_tool_never_writes_its_input_and_replaces_its_output_only_when_asked(tmp_path, capsys):
    path = tmp_path / "in.txt"
    path.write_bytes(CURVED.read_bytes())
    (tmp_path / "link.txt").symlink_to(path)
    for action in ("smooth", "densify", "resample"):
        for out in (path, tmp_path / "link.txt"):
            for more in ([], ["--overwrite"]):
                assert main(["trajectory", action, str(path), str(out), *more]) == 2
                err = capsys.readouterr().err
                assert err == f"vilma trajectory: error: {out}: is the input; give another OUT file\n"
    assert path.read_bytes() == CURVED.read_bytes()
    out = tmp_path / "out.txt"
    out.write_text("mine")
    assert main(["trajectory", "densify", str(path), str(out)]) == 2
    assert capsys.readouterr().err == (f"vilma trajectory: error: {out}: exists; give --overwrite to replace it, or "
                                       "another OUT file\n")
    assert out.read_text() == "mine"
    assert main(["trajectory", "densify", str(path), str(out), "--overwrite"]) == 0
    assert len(load_trajectory(out)) == 2 * 357 - 1
    assert main(["trajectory", "densify", str(path), str(tmp_path), "--overwrite"]) == 2
    assert capsys.readouterr().err == f"vilma trajectory: error: {tmp_path}: is a folder; give another OUT file\n"


def test_a_trajectory_tool_refuses_what_it_cannot_write_and_says_what_its_output_leaves_out(tmp_path, capsys):
    path = tmp_path / "in.csv"
    path.write_text("x,y,speed\n0,0,5\n10,0,5\n20,0,5\n")
    assert main(["trajectory", "info", str(path), str(tmp_path / "o.txt")]) == 2
    assert capsys.readouterr().err == (f"vilma trajectory: error: trajectory info prints what it finds and writes "
                                       f"nothing: drop {tmp_path / 'o.txt'}\n")
    assert main(["trajectory", "densify", str(path), str(tmp_path / "o.gpx")]) == 2
    assert "o.gpx: GPX holds latitudes and longitudes" in capsys.readouterr().err
    assert not (tmp_path / "o.gpx").exists() and not (tmp_path / "o.txt").exists()
    assert main(["trajectory", "densify", str(path), str(tmp_path / "o.txt")]) == 0
    assert capsys.readouterr().out.endswith("without its speeds (the original's format has none: write a .csv to keep "
                                            "them)\n")
    assert main(["trajectory", "densify", str(path), str(tmp_path / "o.csv")]) == 0
    assert np.array_equal(load_trajectory(tmp_path / "o.csv").speed, [5.0] * 5)


@pytest.mark.parametrize("args", [["scenarios"], ["run", "pi_ff_speed_5", "--no-record"]])
def test_a_closed_pipe_ends_the_command_quietly(args, tmp_path):
    """``vilma ... | head -1``: the reader gone, the command ends with no error line and SIGPIPE's status (141), a
    run's files written."""
    read, write = os.pipe()
    os.close(read)  # the reader gone before the command's first line
    out = ["--out", str(tmp_path / "o")] if args[0] == "run" else []
    if out:  # its kernels compiled and cached first: a first compile's notice would be the line the pipe refuses
        assert main([*args, "--out", str(tmp_path / "warm"), "-q"]) == 0
    with os.fdopen(write, "wb") as pipe:
        done = subprocess.run([sys.executable, "-m", "vilma", *args, *out], stdout=pipe, stderr=subprocess.PIPE,
                              text=True, timeout=300, env={**os.environ, "VILMA_SERVE": "off"})
    assert done.returncode == 141 and done.stderr == ""
    assert args[0] != "run" or json.loads((tmp_path / "o" / "metrics.json").read_text())["completed"]


def test_a_broken_pipe_that_is_not_the_output_is_an_error(monkeypatch, capsys):
    def recorder_gone(args):
        raise BrokenPipeError(32, "the recording process has gone")

    monkeypatch.setitem(HANDLERS, "scenarios", recorder_gone)
    assert main(["scenarios"]) == 1  # a peer gone: a failure, not a mistake in the command
    assert capsys.readouterr().err == "vilma scenarios: error: [Errno 32] the recording process has gone\n"


def test_a_cache_naming_a_module_this_process_cannot_import_is_one_line_with_the_way_out(monkeypatch, capsys):
    """A script that drove with a controller kept outside vilma leaves numba's cache index naming its module; a later
    process that cannot import it failed in a traceback from numba's cache (``pickle.loads`` of the index)."""
    numba_reading = compile("raise ModuleNotFoundError(\"No module named 'my_path'\", name='my_path')",
                            "/venv/site-packages/numba/core/caching.py", "exec")

    def run(args):
        exec(numba_reading)

    monkeypatch.setitem(HANDLERS, "scenarios", run)
    assert main(["scenarios"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vilma scenarios: error: numba's cache of vilma's compiled code holds a version made for a "
                          "controller of the module 'my_path', which this process cannot import: put that module on")
    assert err.count("\n") == 1
    monkeypatch.setitem(HANDLERS, "scenarios", lambda args: __import__("no_such_module_of_a_handler"))
    with pytest.raises(ModuleNotFoundError):  # not numba's cache: a bug, shown as one
        main(["scenarios"])


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_sigterm_and_sighup_stop_a_command_as_ctrl_c_with_their_status(monkeypatch, signum, capsys):
    """A job scheduler's SIGTERM and a closed terminal's SIGHUP end a command as Ctrl-C does, with the status a shell
    gives a command that signal ended; a repeat (``timeout`` signals the command and its group) lets it finish."""
    finished = []

    def command(args) -> int:
        try:
            signal.raise_signal(signum)
        finally:
            signal.raise_signal(signum)  # the repeat, while the command writes what it keeps
            finished.append(True)
        return 0

    before = signal.getsignal(signum)
    monkeypatch.setitem(HANDLERS, "scenarios", command)
    assert main(["scenarios"]) == 128 + signum and finished == [True]
    assert signal.getsignal(signum) == before  # the handler is the command's only
    assert capsys.readouterr().err == ""


def test_a_sighup_that_nohup_ignores_stays_ignored(monkeypatch):
    monkeypatch.setitem(HANDLERS, "scenarios", lambda args: signal.raise_signal(signal.SIGHUP) or 0)
    before = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        assert main(["scenarios"]) == 0
    finally:
        signal.signal(signal.SIGHUP, before)


@pytest.mark.parametrize("command", ["up", "sim"])
def test_an_earlier_recording_is_never_replaced(tmp_path, capsys, command):
    earlier = tmp_path / "earlier.mcap"
    earlier.write_bytes(b"an earlier recording")
    assert main([command, "--record", str(earlier), "--duration", "1"]) == 2
    assert capsys.readouterr().err == (f"vilma {command}: error: --record {earlier}: exists; give a new file (an "
                                       "earlier recording is never replaced)\n")
    assert earlier.read_bytes() == b"an earlier recording"


def test_a_full_disk_is_a_failure_not_a_bad_command(tmp_path, capsys, full_disk):
    """Exit 1 (the command was right, the write failed), one line naming the file; the earlier file kept."""
    out = tmp_path / "s.txt"
    out.write_text("earlier")
    assert main(["trajectory", "smooth", str(CURVED), str(out), "--overwrite"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No space left on device" in err and str(out) in err
    assert out.read_text() == "earlier"


def test_ctrl_c_while_a_run_writes_its_files_is_one_line(tmp_path, capsys, monkeypatch):
    """Ctrl-C after the drive, while its files are written: the line says so and where the partial files are."""
    from vilma.record import run as recording

    def interrupted(result, out_dir):
        raise KeyboardInterrupt

    monkeypatch.setattr(recording, "write_metrics", interrupted)
    out = tmp_path / "o"
    assert main(["run", "pi_ff_speed_5", "--set", "duration=1", "--no-record", "--out", str(out)]) == 130
    assert capsys.readouterr().err == f"vilma run: interrupted while writing the run's files: partial files in {out}\n"
    assert not (out / "metrics.json").exists()


@pytest.mark.parametrize(("signum", "status"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_stop_that_lands_in_llvmlite_s_code_is_sent_again_not_dropped(monkeypatch, capsys, signum, status):
    """A callback from C (llvmlite's object cache, numba compiling) prints an exception raised in it and drops it: a
    Ctrl-C or SIGTERM there was lost, and the command ran on."""
    callback = {"__name__": "llvmlite.binding.executionengine", "signal": signal, "signum": signum}
    exec("def compare(a, b):\n    signal.raise_signal(signum)\n    return 0\n", callback)  # (as llvmlite's code)
    order = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p)(callback["compare"])

    def compiling(args):
        ctypes.CDLL(None).qsort((ctypes.c_int * 2)(), 2, ctypes.sizeof(ctypes.c_int), order)  # C calls back
        for _ in range(200):  # (the signal sent again a moment later interrupts this wait)
            time.sleep(0.01)
        return 0

    monkeypatch.setitem(HANDLERS, "scenarios", compiling)
    assert main(["scenarios"]) == status
    assert capsys.readouterr().err == ""
