"""Tuning on Dask: Optuna searches scenario values (a controller's gains, any ``--set`` key) for the best scorecard
objective under constraints, each trial's scenarios run as Dask tasks on the cluster of :mod:`vilma.app.sweep`.

A tune file (YAML; ``scenarios`` and ``params`` and ``objective`` required)::

    scenarios: [course_30kmh_stanley, my_course.yaml]      # as a sweep's
    params:                                                 # --set keys and their search spaces
      path_controller.k: {loguniform: [0.1, 10]}
      speed_controller.kp: {uniform: [0.5, 2]}
      driver.lookahead_points: {int: [1, 8]}
      pose: {choice: [truth, ekf]}
    objective: {minimize: lateral_error_rms_m, aggregate: mean}   # or maximize; mean or max over the scenarios
    constraints: {steering_rate_rms_radps: {max: 0.5}, completed: true}   # each on every scenario
    trials: 40
    seed: 0                                                 # the sampler's (TPE)
"""

from __future__ import annotations

import json
import logging
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
from distributed import wait
from distributed.client import FuturesCancelledError
from rich.console import Console
from rich.table import Table
from rich.text import Text

from vilma.app.sweep import PNG_DPI, connect, dask_logs, needs, run_remote, warm, write_table
from vilma.app.sweep_plan import _finite, _scenarios
from vilma.core.files import atomic_path
from vilma.scenario.fields import Source, SpecError, _suggest, read_yaml
from vilma.scenario.metrics import unmeasured
from vilma.scenario.report import agg_figure, write_png
from vilma.scenario.scorecard import BOOLEAN_KEYS, SCORECARD_KEYS
from vilma.scenario.spec import load_scenario, to_yaml

KEYS = ("scenarios", "params", "objective", "constraints", "trials", "seed")
"""The keys of a tune file."""
SPACES = ("uniform", "loguniform", "int", "choice")
"""The search spaces of ``params``."""
AGGREGATES = ("mean", "max")
"""How a trial's objective comes from its scenarios' values."""
WORDS = ("incomplete_reason", "traffic", "perception", "planner", "planner_reason")
"""Scorecard keys whose values are words: no objective, and only an equality constraint."""
MAX_INT = 2**53
"""The largest bound of an ``int`` space: Optuna's TPE draws whole numbers as floats, exact up to 2**53."""
MAX_TRIALS = 10_000
"""Trials one tune may ask for (each is a row held in memory)."""
CSV, PARQUET, BEST, HISTORY = "trials.csv", "trials.parquet", "best.yaml", "history.png"
"""The files of a tune's folder."""


@dataclass(frozen=True, slots=True)
class Param:
    """A ``--set`` key and its search space."""

    key: str
    space: str
    args: tuple

    def suggest(self, trial) -> Any:
        """The value Optuna's ``trial`` asks for."""
        if self.space == "choice":
            return trial.suggest_categorical(self.key, list(self.args))
        if self.space == "int":
            return trial.suggest_int(self.key, *self.args)
        return trial.suggest_float(self.key, *self.args, log=self.space == "loguniform")

    def ends(self) -> tuple:
        """The values that bound the space: every one a scenario must take."""
        return self.args if self.space == "choice" else (self.args[0], self.args[-1])


@dataclass(frozen=True, slots=True)
class Constraint:
    """A scorecard key that must hold on every scenario: a value (``completed: true``) or bounds."""

    key: str
    equal: Any = None
    min: float | None = None
    max: float | None = None

    def violation(self, value: Any) -> float:
        """How far ``value`` breaks it (> 0), or its margin (<= 0), in the key's unit (1 or 0 for an equality)."""
        if self.equal is not None:
            return 0.0 if value == self.equal else 1.0
        return max(value - self.max if self.max is not None else -math.inf,
                   self.min - value if self.min is not None else -math.inf)


@dataclass(frozen=True, slots=True)
class TunePlan:
    """What a tune file asks for."""

    scenarios: tuple[str, ...]
    params: tuple[Param, ...]
    key: str
    """The objective's scorecard key."""
    direction: str
    """``minimize`` or ``maximize``."""
    aggregate: str
    constraints: tuple[Constraint, ...]
    trials: int
    seed: int


def read_tune(path: str | Path) -> TunePlan:
    """The tune file ``path``, each scenario loaded with each end of each space (a bad value stops it here).

    Raises:
        SpecError: an unknown key or a bad value (``file:line``), or a scenario that does not load.
    """
    data, src = read_yaml(Path(path))
    if not isinstance(data, Mapping):
        raise src.error((), "expected a mapping with scenarios, params, objective (and constraints, trials, seed)")
    for k in data:
        if k not in KEYS:
            raise src.error((k,), f"unknown key{_suggest(str(k), dict.fromkeys(KEYS))}")
    for k, example in (("scenarios", "[pi_ff_speed_10]"), ("params", "{speed_controller.kp: {uniform: [0.5, 2]}}"),
                       ("objective", "{minimize: speed_error_rms_mps}")):
        if k not in data:
            raise src.error((), f"missing {k}: add e.g. {k}: {example}")
    key, direction, aggregate = _objective(data["objective"], src)
    plan = TunePlan(tuple(_scenarios(data["scenarios"], src, Path(path).parent)), _params(data["params"], src), key,
                    direction, aggregate, _constraints(data.get("constraints") or {}, src),
                    _whole(data.get("trials", 20), src, "trials", 1, MAX_TRIALS), _whole(data.get("seed", 0), src,
                                                                                         "seed", 0, 2**32 - 1))
    for label in plan.scenarios:  # every value a trial may take loads (each space's ends, each choice)
        never = None  # the keys no run of it measures with any of these values
        for p in plan.params:
            for v in p.ends():
                try:
                    scenario = load_scenario(label, {p.key: json.dumps(v)})
                except SpecError as e:
                    raise SpecError(f"{src.where(('params', p.key))}: {e}") from None
                never = {k: why for k, why in unmeasured(scenario).items() if never is None or k in never}
        keys = [(("objective", direction), plan.key), *((("constraints", c.key), c.key) for c in plan.constraints)]
        for where, k in keys:
            if k in never:
                raise src.error(where, f"{label} never measures {k} ({never[k]}); choose another key or scenario")
    return plan


def _objective(raw: Any, src: Source) -> tuple[str, str, str]:
    """``{minimize: KEY}`` or ``{maximize: KEY}``, with ``aggregate: mean | max``."""
    shape = "expected {minimize: KEY} or {maximize: KEY} (a scorecard key), and aggregate: mean or max"
    if not isinstance(raw, Mapping):
        raise src.error(("objective",), shape)
    for k in raw:
        if k not in ("minimize", "maximize", "aggregate"):
            raise src.error(("objective", k), f"unknown key; {shape}")
    directions = [k for k in raw if k != "aggregate"]
    if len(directions) != 1:
        raise src.error(("objective",), shape)
    (direction,) = directions
    key, aggregate = raw[direction], raw.get("aggregate", "mean")
    if key not in SCORECARD_KEYS or key in WORDS:
        raise src.error(("objective", direction), f"not a number of the scorecard{_suggest(str(key), _NUMBERS)}")
    if aggregate not in AGGREGATES:
        raise src.error(("objective", "aggregate"), f"expected one of {', '.join(AGGREGATES)}, got {aggregate!r}")
    return key, direction, aggregate


_NUMBERS = dict.fromkeys(k for k in SCORECARD_KEYS if k not in WORDS)


def _params(raw: Any, src: Source) -> tuple[Param, ...]:
    """``KEY: {space: [arguments]}`` for each searched ``--set`` key."""
    if not isinstance(raw, Mapping) or not raw:
        raise src.error(("params",), "expected a mapping of --set keys to search spaces, e.g. "
                                     "speed_controller.kp: {uniform: [0.5, 2]}")
    out = []
    for k, v in raw.items():
        where = ("params", k)
        if not isinstance(v, Mapping) or len(v) != 1:
            raise src.error(where, f"expected one search space, e.g. {{uniform: [0, 1]}}; known: {', '.join(SPACES)}")
        (space, args), = v.items()
        if space not in SPACES:
            raise src.error((*where, space), f"unknown search space{_suggest(str(space), dict.fromkeys(SPACES))}")
        if not _fits(space, args):
            shape = {"choice": "[option, option, ...] of finite numbers, words or booleans",
                     "int": f"[low, high], whole numbers within ±{MAX_INT}, low < high",
                     "loguniform": "[low, high], finite numbers, 0 < low < high"}.get(
                space, "[low, high], low < high, finite numbers at most 1.8e308 apart")
            raise src.error((*where, space), f"expected {shape}, got {args!r}")
        out.append(Param(str(k), space, tuple(args)))
    return tuple(out)


def _fits(space: str, args: Any) -> bool:
    """Whether ``args`` are arguments of ``space``."""
    if not isinstance(args, list) or not args:
        return False
    if space == "choice":
        return all(isinstance(a, bool | str) or _finite(a) for a in args)
    kind = int if space == "int" else int | float
    return (len(args) == 2 and all(isinstance(a, kind) and not isinstance(a, bool) for a in args)
            and args[0] < args[1] and _finite(args[1] - args[0]) and (space != "loguniform" or args[0] > 0)
            and (space != "int" or -MAX_INT <= args[0] < args[1] <= MAX_INT))


def _constraints(raw: Any, src: Source) -> tuple[Constraint, ...]:
    """``KEY: value`` (the value on every scenario) or ``KEY: {min: a, max: b}``."""
    if not isinstance(raw, Mapping):
        raise src.error(("constraints",), "expected a mapping of scorecard keys to a value (completed: true) or "
                                          "bounds ({max: 0.5})")
    out = []
    for k, v in raw.items():
        if k not in SCORECARD_KEYS:
            raise src.error(("constraints", k), f"not a scorecard key{_suggest(str(k), dict.fromkeys(SCORECARD_KEYS))}")
        if not isinstance(v, Mapping):  # a value of the key's kind: one a scorecard may hold
            kind, ok = "a finite number", _finite(v) and not isinstance(v, bool)
            if k in WORDS:
                kind, ok = "a word", isinstance(v, str)
            elif k in BOOLEAN_KEYS:
                kind, ok = "true or false", isinstance(v, bool)
            if not ok:
                raise src.error(("constraints", k), f"expected {kind} (or bounds {{min: a, max: b}} on a number), "
                                                    f"got {v!r}")
            out.append(Constraint(str(k), equal=v))
            continue
        bad = [b for b in v if b not in ("min", "max")]
        numbers = all(_finite(x) and not isinstance(x, bool) for x in v.values())
        if (bad or not v or not numbers or k in (*WORDS, *BOOLEAN_KEYS)
                or v.get("min", -math.inf) > v.get("max", math.inf)):
            raise src.error(("constraints", k, *bad[:1]), f"expected bounds {{min: a, max: b}} (finite numbers, "
                                                          f"a <= b) on a number of the scorecard, got {dict(v)!r}")
        out.append(Constraint(str(k), min=v.get("min"), max=v.get("max")))
    return tuple(out)


def _whole(raw: Any, src: Source, key: str, low: int, high: int) -> int:
    if isinstance(raw, bool) or not isinstance(raw, int) or not low <= raw <= high:
        raise src.error((key,), f"expected a whole number from {low} to {high}, got {raw!r}")
    return raw


def tune(plan: str | Path | TunePlan, out: str | Path | None = None, *, workers: int | None = None,
         scheduler: str | None = None, console: Console | None = None) -> pd.DataFrame:
    """Search ``plan`` (a tune file or :func:`read_tune`'s) with Optuna's TPE on Dask; returns the trials, a row each
    (``number``, the params, ``objective``, each constraint's value on its worst scenario, ``feasible``, ``error``).

    Each batch asks as many trials as the cluster has workers, runs their scenarios as Dask tasks and tells their
    results: the same seed and trials on one worker search the same values. With ``out``, the trials go to
    ``trials.csv`` and ``trials.parquet``, their history to ``history.png`` and the best trial's values, applied to
    the first scenario, to ``best.yaml``.

    Raises:
        SpecError: a bad tune file, or ``out`` holds an earlier tune.
        KeyboardInterrupt, ConnectionError: Ctrl-C, or the scheduler was lost; the finished trials are written.
    """
    import optuna

    plan = read_tune(plan) if isinstance(plan, str | Path) else plan
    out = Path(out) if out is not None else None
    if out is not None and (out / CSV).exists():
        raise SpecError(f"{out}: holds an earlier tune ({CSV}); move it or give another --out")
    console = console or Console(quiet=True)
    optuna.logging.set_verbosity(optuna.logging.WARNING)  # a line a trial comes from here instead
    study = optuna.create_study(direction=plan.direction, sampler=optuna.samplers.TPESampler(seed=plan.seed))
    rows: list[dict] = []
    try:
        with connect(workers, scheduler) as client:
            scenarios = [load_scenario(label) for label in plan.scenarios]
            warm(client, scenarios[0], needs(scenarios))
            batch = max(1, len(client.scheduler_info()["workers"]))
            while len(rows) < plan.trials:
                trials = [study.ask() for _ in range(min(batch, plan.trials - len(rows)))]
                for trial, row in zip(trials, _evaluate(client, plan, trials), strict=True):
                    _tell(study, plan, trial, row)
                    rows.append(row)
                    console.print(Text(f"[{len(rows)}/{plan.trials}] trial {row['number']}: {_outcome(plan, row)}"))
    except (KeyboardInterrupt, ConnectionError) as e:
        why = f"{e}" if isinstance(e, ConnectionError) else "interrupted"
        kept = f": {len(rows)} of {plan.trials} trials kept in {out}"
        raise type(e)(why + (kept if out is not None else "")) from None
    finally:
        table = trials_table(plan, rows)
        if out is not None and rows:
            write_tune(plan, table, out)
    return table


def _outcome(plan: TunePlan, row: dict) -> str:
    """What a trial came to, in a few words."""
    if row["error"] is not None:
        return row["error"]
    return f"{plan.key} {row['objective']:.6g}{'' if row['feasible'] else ', breaks a constraint'}"


def _evaluate(client, plan: TunePlan, trials: Sequence) -> list[dict]:
    """Run the scenarios of each trial (a Dask task each, all at once); a row a trial."""
    jobs = []
    for trial in trials:
        values = {p.key: p.suggest(trial) for p in plan.params}
        try:
            scenarios = [load_scenario(label, {k: json.dumps(v) for k, v in values.items()})
                         for label in plan.scenarios]
        except SpecError as e:  # a value inside the space the scenario refuses with the others (a trial's failure)
            jobs.append((trial, values, str(e)))
            continue
        jobs.append((trial, values, [client.submit(run_remote, s, pure=False) for s in scenarios]))
    try:
        wait([f for *_, fs in jobs if isinstance(fs, list) for f in fs])
    except FuturesCancelledError:  # (Dask cancels every future of a client that lost its scheduler)
        raise ConnectionError(f"lost the Dask scheduler ({client.scheduler.address})") from None
    rows = []
    for trial, values, futures in jobs:
        if isinstance(futures, str):
            rows.append(_row(plan, trial.number, values, [], futures))
            continue
        if any(f.status == "cancelled" for f in futures):
            raise ConnectionError(f"lost the Dask scheduler ({client.scheduler.address})")
        results = [f.result() if f.status == "finished" else {"error": f"{f.exception()}"} for f in futures]
        errors = [f"{label}: {r['error']}" for label, r in zip(plan.scenarios, results, strict=True) if r["error"]]
        rows.append(_row(plan, trial.number, values, results, errors[0] if errors else None))
    return rows


def _row(plan: TunePlan, number: int, values: dict, results: list[dict], error: str | None) -> dict:
    """A trial's row from its scenarios' scorecards (``results``, in the order of ``plan.scenarios``)."""
    row = {"number": number, **values, "objective": math.nan, **dict.fromkeys(c.key for c in plan.constraints),
           "feasible": False, "error": error}
    if error is not None:
        return row
    missing = [f"{label}: no {k} in its scorecard" for label, r in zip(plan.scenarios, results, strict=True)
               for k in (plan.key, *(c.key for c in plan.constraints)) if r[k] is None]
    if missing:  # a key this kind of task does not measure (a path error of a speed task)
        return {**row, "error": missing[0]}
    scores = [float(r[plan.key]) for r in results]
    worst = {c.key: max((r[c.key] for r in results), key=c.violation) for c in plan.constraints}
    return {**row, "objective": max(scores) if plan.aggregate == "max" else sum(scores) / len(scores), **worst,
            "feasible": all(c.violation(worst[c.key]) <= 0 for c in plan.constraints)}


def _tell(study, plan: TunePlan, trial, row: dict) -> None:
    """Tell Optuna a trial's result. A trial that breaks a constraint is complete, its violations told with
    ``set_constraint`` (Optuna 5's form of TPE's ``constraints_func``): TPE learns from how far it missed. A trial
    that failed (a run's error, a scorecard key missing) is told failed: there is no value to learn from."""
    from optuna.trial import TrialState

    if row["error"] is not None:
        study.tell(trial, state=TrialState.FAIL)
        return
    for c in plan.constraints:
        trial.set_constraint(c.key, c.violation(row[c.key]))
    study.tell(trial, row["objective"])


def trials_table(plan: TunePlan, rows: list[dict]) -> pd.DataFrame:
    """The trials' rows in order of their number, the columns in the order of :func:`tune`'s table."""
    columns = ["number", *(p.key for p in plan.params), "objective", *(c.key for c in plan.constraints), "feasible",
               "error"]
    return pd.DataFrame(sorted(rows, key=lambda r: r["number"]), columns=columns)


def best_trial(plan: TunePlan, table: pd.DataFrame) -> pd.Series | None:
    """The feasible trial with the best objective (the first of equals), or ``None`` if no trial is feasible."""
    feasible = table[table["feasible"].astype(bool)]
    if feasible.empty:
        return None
    scores = feasible["objective"].astype(float)
    return feasible.loc[scores.idxmin() if plan.direction == "minimize" else scores.idxmax()]


def best_values(plan: TunePlan, best: pd.Series) -> dict[str, Any]:
    """The winning value of each param (as the trial's table holds it, a whole number as an int)."""
    return {p.key: int(best[p.key]) if p.space == "int" else _plain(best[p.key]) for p in plan.params}


def _plain(v: Any) -> Any:
    return v.item() if hasattr(v, "item") else v


def write_tune(plan: TunePlan, table: pd.DataFrame, out: Path) -> None:
    """``trials.csv``, ``trials.parquet`` and ``history.png`` in ``out``, and ``best.yaml`` if a trial is feasible;
    each file whole or not at all."""
    out.mkdir(parents=True, exist_ok=True)
    numbers = table.copy()
    for c in plan.constraints:  # a worst value that is sometimes missing (a failed trial): a number or none
        if c.equal is None:
            numbers[c.key] = pd.to_numeric(numbers[c.key])
    write_table(numbers, out, CSV, PARQUET)  # a choice of words and numbers goes as text
    draw_history(plan, table, out / HISTORY)
    best = best_trial(plan, table)
    if best is not None:
        scenario = load_scenario(plan.scenarios[0], {k: json.dumps(v) for k, v in best_values(plan, best).items()})
        with atomic_path(out / BEST) as tmp:
            Path(tmp).write_text(to_yaml(scenario), encoding="utf-8")


def draw_history(plan: TunePlan, table: pd.DataFrame, path: Path) -> None:
    """The objective of each trial (feasible as dots, infeasible as crosses) and the best feasible so far."""
    fig = agg_figure(8, 5, dpi=PNG_DPI)
    ax = fig.add_subplot()
    ok = table["feasible"].astype(bool)
    score = table["objective"].astype(float)
    ax.plot(table["number"][ok], score[ok], "o", label="feasible")
    ax.plot(table["number"][~ok], score[~ok], "x", color="grey", label="infeasible")
    kept = score.where(ok)
    so_far = kept.cummin() if plan.direction == "minimize" else kept.cummax()
    ax.step(table["number"], so_far, where="post", color="C3", label="best so far")
    ax.set_xlabel("trial")
    ax.set_ylabel(f"{plan.key} ({plan.aggregate} over {len(plan.scenarios)} scenarios)")
    ax.set_title(f"vilma tune: {plan.direction} {plan.key}, {len(table)} trials")
    ax.legend()
    fig.tight_layout()
    write_png(fig, path, PNG_DPI)


def tune_command(args, console: Console) -> int:
    """``vilma tune TUNE.yaml``: search, write, print the best values; 1 if no trial met the constraints."""
    dask_logs(logging.CRITICAL if args.verbose < 1 else logging.getLogger().level)
    plan = read_tune(args.tune)
    out = Path(args.out) if args.out else Path("tunes") / Path(args.tune).stem
    console.print(f"vilma tune: {plan.trials} trials of {len(plan.scenarios)} scenarios on "
                  f"{args.scheduler or 'a local Dask cluster'}, table in {out}", highlight=False)
    table = tune(plan, out, workers=args.workers, scheduler=args.scheduler, console=console)
    for error in table["error"].dropna().unique()[:10]:
        console.print(Text(f"FAIL: {error}"), style="red")
    best = best_trial(plan, table)
    if best is None:
        errors = table["error"].dropna()  # every trial failed: say why, not that the constraints are too tight
        why = (f"all {len(table)} trials failed, e.g. {errors.iloc[0]}" if len(errors) == len(table) else
               f"none of {len(table)} trials met the constraints ({len(errors)} failed); loosen them or search other "
               "values")
        print(f"vilma tune: no best: {why} (trials in {out / CSV})", file=sys.stderr)
        return 1
    console.print(best_table(plan, best))
    console.print(Text(f"best scenario: {out / BEST} (vilma run {out / BEST})"))
    return 0


def best_table(plan: TunePlan, best: pd.Series) -> Table:
    """The best trial's values and objective."""
    out = Table(title=f"vilma tune: best of trial {int(best['number'])}")
    out.add_column("key")
    out.add_column("value", justify="right")
    for k, v in best_values(plan, best).items():
        out.add_row(Text(k), Text(f"{v:.6g}" if isinstance(v, float) else str(v)))
    out.add_row(Text(f"{plan.key} ({plan.aggregate})"), Text(f"{float(best['objective']):.6g}"))
    return out
