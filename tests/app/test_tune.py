"""``vilma tune``: Optuna's search on Dask (a local cluster, a real ``dask scheduler`` and ``dask worker``), its
table and best.yaml, infeasible searches and bad tune files."""

from __future__ import annotations

import dataclasses
import subprocess
import sys

import pandas as pd
import pytest
from distributed import Client

from tests.conftest import Processes, free_port
from vilma.app import tune
from vilma.app.cli import main
from vilma.scenario.runner import run
from vilma.scenario.spec import load_scenario

DASK = (sys.executable, "-m", "dask")
SHORT = "pi_ff_speed_10"
"""A bundled speed step to 10 m/s, cut to 4 to 6 s in these tunes."""
GAINS = (f"scenarios: [{SHORT}]\n"
         "params:\n"
         "  duration: {int: [4, 6]}\n"
         "  speed_controller.kp: {uniform: [0.3, 3]}\n"
         "  speed_controller.ki: {loguniform: [0.05, 1]}\n"
         "  initial.speed: {choice: [0, 2]}\n"
         "objective: {minimize: speed_error_rms_mps}\n")
"""A tune of the speed loop's gains, without constraints, trials and seed."""


def _file(tmp_path, text: str):
    path = tmp_path / "t.yaml"
    path.write_text(text)
    return path


@pytest.mark.slow
def test_the_best_trial_is_the_best_feasible_one_and_best_yaml_scores_it(tmp_path):
    path = _file(tmp_path, GAINS + "constraints: {completed: true, speed_overshoot_pct: {max: 0.5}}\ntrials: 5\n"
                                   "seed: 3\n")
    table = tune.tune(path, tmp_path / "out", workers=1)
    assert list(table["number"]) == list(range(5)) and table["error"].isna().all()
    # feasible: complete and within the bound, as the constraints define it
    assert list(table["feasible"]) == list(table["completed"].eq(True) & (table["speed_overshoot_pct"] <= 0.5))
    assert table["feasible"].any()
    best_score = table.loc[table["feasible"], "objective"].min()
    scenario = load_scenario(str(tmp_path / "out" / tune.BEST))
    best = table[table["objective"] == best_score].iloc[0]
    gains = scenario.driver.gains_of("pi_ff")
    assert (gains.kp, gains.ki, scenario.duration, scenario.initial.speed) == (
        best["speed_controller.kp"], best["speed_controller.ki"], best["duration"], best["initial.speed"])
    assert run(scenario).metrics["speed_error_rms_mps"] == best_score  # one scenario: its mean is its value
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "out" / tune.PARQUET), table, check_dtype=False)
    assert len(pd.read_csv(tmp_path / "out" / tune.CSV)) == 5 and (tmp_path / "out" / tune.HISTORY).stat().st_size


@pytest.mark.slow
def test_the_same_seed_on_one_worker_searches_the_same_values(tmp_path):
    path = _file(tmp_path, GAINS + "trials: 3\nseed: 11\n")
    first, again = tune.tune(path, workers=1), tune.tune(path, workers=1)
    pd.testing.assert_frame_equal(first, again)
    other = tune.tune(_file(tmp_path, GAINS + "trials: 3\nseed: 12\n"), workers=1)
    assert list(other["speed_controller.kp"]) != list(first["speed_controller.kp"])


@pytest.mark.slow
def test_a_constraint_no_trial_meets_gives_no_best_and_exit_1(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # from 0 or 2 m/s to 10 m/s the speed error starts at 8 m/s or more: its RMS over the run is never 0
    _file(tmp_path, GAINS + "constraints: {speed_error_rms_mps: {max: 0}}\ntrials: 3\n")
    assert main(["tune", "t.yaml", "--workers", "1", "--out", "out"]) == 1
    err = capsys.readouterr().err
    assert err == ("vilma tune: no best: none of 3 trials met the constraints (0 failed); loosen them or search other "
                   "values (trials in out/trials.csv)\n")
    table = pd.read_csv(tmp_path / "out" / tune.CSV)
    assert not table["feasible"].any() and (table["speed_error_rms_mps"] > 0).all()
    assert not (tmp_path / "out" / tune.BEST).exists() and (tmp_path / "out" / tune.HISTORY).exists()


@pytest.mark.slow
def test_ctrl_c_keeps_the_finished_trials(tmp_path, monkeypatch):
    tell = tune._tell

    def tell_then_ctrl_c(study, plan, trial, row):
        tell(study, plan, trial, row)
        if row["number"] == 1:
            raise KeyboardInterrupt

    monkeypatch.setattr(tune, "_tell", tell_then_ctrl_c)
    with pytest.raises(KeyboardInterrupt, match=r"^interrupted: 1 of 4 trials kept in "):
        tune.tune(_file(tmp_path, GAINS + "trials: 4\n"), tmp_path / "out", workers=1)
    assert list(pd.read_csv(tmp_path / "out" / tune.CSV)["number"]) == [0]


@pytest.mark.slow
def test_a_key_a_run_does_not_measure_fails_each_trial_and_the_summary_says_so(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    # 9 m/s from at most 2 m/s takes at least 7 / (6000 N / 1211 kg) = 1.4 s at the car's largest drive force:
    # runs of 1 s never rise to 90 % of 10 m/s
    _file(tmp_path, GAINS.replace("{int: [4, 6]}", "{choice: [1]}").replace("speed_error_rms_mps",
                                                                            "speed_rise_time_90_s") + "trials: 2\n")
    assert main(["tune", "t.yaml", "--workers", "1", "--out", "out"]) == 1
    table = pd.read_csv(tmp_path / "out" / tune.CSV)
    missing = f"{SHORT}: no speed_rise_time_90_s in its scorecard"
    assert list(table["error"]) == [missing] * 2 and not table["feasible"].any()
    err = capsys.readouterr().err
    assert err == f"vilma tune: no best: all 2 trials failed, e.g. {missing} (trials in out/trials.csv)\n"


@pytest.mark.slow
def test_a_tune_on_a_real_scheduler_and_worker(tmp_path):
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    with Processes() as processes:
        processes.start(*DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
        processes.start(*DASK, "worker", address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                        "--no-dashboard")
        with Client(address, timeout=60) as client:
            client.wait_for_workers(1, timeout=120)
        table = tune.tune(_file(tmp_path, GAINS + "trials: 2\n"), tmp_path / "out", scheduler=address)
    assert list(table["number"]) == [0, 1] and table["error"].isna().all() and table["feasible"].all()
    assert (tmp_path / "out" / tune.BEST).exists()


@pytest.mark.slow
def test_a_lost_scheduler_keeps_the_finished_trials_and_exits_2(tmp_path, processes):
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    lost = processes.start(*DASK, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
    processes.start(*DASK, "worker", address, "--nthreads", "1", "--no-nanny", "--host", "127.0.0.1",
                    "--no-dashboard")
    _file(tmp_path, GAINS + f"trials: {tune.MAX_TRIALS}\n")
    p = processes.vilma("tune", "t.yaml", "--scheduler", address, "--out", "out", cwd=tmp_path)
    for line in p.stdout:
        if line.startswith(f"[3/{tune.MAX_TRIALS}]"):
            lost.kill()
            break
    rest = p.communicate(timeout=120)[0]
    assert p.returncode == 1, rest  # a failure, not a mistake in the command
    kept = pd.read_csv(tmp_path / "out" / tune.CSV)
    assert 3 <= len(kept) < tune.MAX_TRIALS and kept["error"].isna().all()
    (error,) = [line for line in rest.splitlines() if not line.startswith("[")]
    assert error == (f"vilma tune: error: lost the Dask scheduler ({address}): {len(kept)} of {tune.MAX_TRIALS} "
                     "trials kept in out")


@pytest.mark.parametrize(("text", "message"), [
    (GAINS + "trails: 3\n", "t.yaml:8: trails: unknown key; did you mean 'trials'?"),
    (GAINS.replace("uniform: [0.3, 3]", "uniform: [3, 0.3]"),
     "t.yaml:4: params.speed_controller.kp.uniform: expected [low, high], low < high, finite numbers at most "
     "1.8e308 apart, got [3, 0.3]"),
    (GAINS.replace("loguniform: [0.05, 1]", "loguniform: [0, 1]"),
     "t.yaml:5: params.speed_controller.ki.loguniform: expected [low, high], finite numbers, 0 < low < high"),
    (GAINS.replace("{uniform: [0.3, 3]}", "{int: [1, 2.5]}"),
     "t.yaml:4: params.speed_controller.kp.int: expected [low, high], whole numbers"),
    (GAINS.replace("{uniform: [0.3, 3]}", "{gauss: [1, 2]}"),
     "t.yaml:4: params.speed_controller.kp.gauss: unknown search space"),
    (GAINS.replace("speed_error_rms_mps", "speed_eror_rms_mps"),
     "t.yaml:7: objective.minimize: not a number of the scorecard; did you mean 'speed_error_rms_mps'?"),
    (GAINS.replace("speed_error_rms_mps}", "speed_error_rms_mps, aggregate: median}"),
     "t.yaml:7: objective.aggregate: expected one of mean, max, got 'median'"),
    (GAINS + "constraints: {speed_overshoot_pct: {max: 1, top: 2}}\n",
     "t.yaml:8: constraints.speed_overshoot_pct.top: expected bounds {min: a, max: b}"),
    (GAINS + "constraints: {overshoot: {max: 1}}\n", "t.yaml:8: constraints.overshoot: not a scorecard key"),
    (GAINS + "trials: 0\n", "t.yaml:8: trials: expected a whole number from 1 to 10000, got 0"),
    (GAINS.replace("{uniform: [0.3, 3]}", "{uniform: [-1, 3]}"),  # an end of the space the controller refuses
     "t.yaml:4: --set speed_controller.kp=-1: speed_controller.kp: pi_ff kp must be a finite number >= 0, got -1"),
    (GAINS.replace(f"[{SHORT}]", "[nope]"), "nope: no such file, nor a bundled scenario"),
    (GAINS.replace("{uniform: [0.3, 3]}", "{uniform: [0.3, .inf]}"),
     "t.yaml:4: params.speed_controller.kp.uniform: expected [low, high], low < high, finite numbers"),
    (GAINS.replace("{uniform: [0.3, 3]}", "{uniform: [-1.0e+308, 1.0e+308]}"),  # Optuna's draw overflowed
     "t.yaml:4: params.speed_controller.kp.uniform: expected [low, high], low < high, finite numbers at most "
     "1.8e308 apart"),
    (GAINS.replace("{int: [4, 6]}", f"{{int: [4, {2**63}]}}"),  # the trials' table held no such int
     "t.yaml:3: params.duration.int: expected [low, high], whole numbers within ±9007199254740992"),
    (GAINS.replace("choice: [0, 2]", "choice: [0, .nan]"),
     "t.yaml:6: params.initial.speed.choice: expected [option, option, ...] of finite numbers"),
    (GAINS + "constraints: {speed_overshoot_pct: {max: .nan}}\n",  # Optuna refused the NaN once the cluster ran
     "t.yaml:8: constraints.speed_overshoot_pct: expected bounds {min: a, max: b} (finite numbers, a <= b)"),
    (GAINS + "constraints: {completed: yes please}\n",  # no trial could meet these
     "t.yaml:8: constraints.completed: expected true or false (or bounds {min: a, max: b} on a number), got "
     "'yes please'"),
    (GAINS + "constraints: {speed_overshoot_pct: .nan}\n",
     "t.yaml:8: constraints.speed_overshoot_pct: expected a finite number (or bounds"),
    (GAINS + "constraints: {traffic: 3}\n", "t.yaml:8: constraints.traffic: expected a word"),
    (GAINS + "constraints: {completed: {min: 1}}\n", "t.yaml:8: constraints.completed: expected bounds"),
    # keys no run of a speed task on flat ground measures, whatever its values
    (GAINS.replace("minimize: speed_error_rms_mps", "maximize: min_distance_to_traffic_m"),
     f"t.yaml:7: objective.maximize: {SHORT} never measures min_distance_to_traffic_m (it has no CommonRoad road, "
     "nor boxes or cones on flat ground); choose another key or scenario"),
    (GAINS.replace("speed_error_rms_mps", "lateral_error_rms_m"),
     f"t.yaml:7: objective.minimize: {SHORT} never measures lateral_error_rms_m (a speed task has no path)"),
    (GAINS + "constraints: {goal_reached: true}\n",
     f"t.yaml:8: constraints.goal_reached: {SHORT} never measures goal_reached (it has no CommonRoad road)"),
    (GAINS.replace("objective: {minimize: speed_error_rms_mps}\n", ""),
     "t.yaml:1: missing objective: add e.g. objective: {minimize: speed_error_rms_mps}"),
])
def test_bad_tune_files_are_one_line_and_exit_2_before_any_run(text, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _file(tmp_path, text)
    assert main(["tune", "t.yaml"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("vilma tune: error: ") and message in err and err.count("\n") == 1, err
    assert not (tmp_path / "tunes").exists()


def test_an_earlier_tune_is_kept(tmp_path, capsys):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / tune.CSV).write_text("number\n0\n")
    assert main(["tune", str(_file(tmp_path, GAINS)), "--out", str(tmp_path / "out")]) == 2
    assert "holds an earlier tune (trials.csv); move it or give another --out" in capsys.readouterr().err
    assert (tmp_path / "out" / tune.CSV).read_text() == "number\n0\n"


def test_a_constraint_on_every_scenario_is_its_worst_value_and_the_objective_their_mean_or_max():
    bounds = tune.Constraint("r", min=1.0, max=2.0)
    plan = tune.TunePlan(("a", "b"), (), "x", "minimize", "max", (tune.Constraint("completed", equal=True), bounds),
                         1, 0)
    rows = [{"x": 1.0, "completed": True, "r": 1.5}, {"x": 3.0, "completed": False, "r": 2.5}]
    row = tune._row(plan, 0, {}, rows, None)
    assert (row["objective"], row["completed"], row["r"], row["feasible"]) == (3.0, False, 2.5, False)
    mean = dataclasses.replace(plan, aggregate="mean", constraints=(bounds,))
    row = tune._row(mean, 0, {}, [{"x": 1.0, "r": 0.5}, {"x": 3.0, "r": 2.2}], None)  # 0.5 below, 0.2 above
    assert (row["objective"], row["r"], row["feasible"]) == (2.0, 0.5, False)
    assert tune._row(mean, 0, {}, [{"x": 1.0, "r": 1.0}, {"x": 3.0, "r": 2.0}], None)["feasible"]  # bounds hold


def test_vilma_help_does_not_import_optuna():
    code = ("import sys\nfrom vilma.app.cli import main\ntry:\n    main(['tune', '--help'])\nexcept SystemExit:\n"
            "    pass\nprint('optuna' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True).stdout
    assert "TUNE.yaml" in out and "--scheduler" in out and out.endswith("False\n")
