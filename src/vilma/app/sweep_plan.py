"""A sweep's plan: the runs of a sweep file (scenarios times a grid, random samples and Monte-Carlo seeds) or of
``vilma run ... --set``, each loaded and checked before the first starts, each with a stable key.

A sweep file (YAML; every key optional but ``scenarios``)::

    scenarios: [paper_fig11_speed_10, my_scenarios/]    # files, bundled names, CommonRoad .xml, folders of them
    grid: {task.speed: [5, 10, 15], duration: 30}       # --set keys: a list sweeps, a value is fixed ([[1, 2]]: a list)
    samples:                                             # random draws, each run with every grid point
      count: 20
      seed: 1
      values: {initial.speed: {uniform: [0, 2]}, driver.actuation_delay: {choice: [true, false]}}
    seeds: 10                                            # Monte-Carlo seeds 0..9, or a list [3, 7]
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from vilma.app.batch import parse_sets
from vilma.scenario.fields import Source, SpecError, _suggest, read_yaml
from vilma.scenario.spec import Scenario, load_scenario

KEYS = ("scenarios", "grid", "samples", "seeds")
"""The keys of a sweep file."""
SAMPLE_KEYS = ("count", "seed", "values")
DISTRIBUTIONS = {  # name -> (its arguments, a draw from numpy's Generator)
    "uniform": ("[low, high], low < high, finite numbers at most 1.8e308 apart", lambda g, a: g.uniform(*a)),
    "normal": ("[mean, std], finite numbers, std >= 0", lambda g, a: g.normal(*a)),
    "loguniform": ("[low, high], finite numbers, 0 < low < high",
                   lambda g, a: math.exp(g.uniform(math.log(a[0]), math.log(a[1])))),
    "choice": ("[option, option, ...], numbers finite", lambda g, a: a[int(g.integers(len(a)))]),
}
"""The distributions of ``samples.values``."""
CONFIRM_RUNS = 10_000
"""Runs a sweep may ask for without ``--yes`` (or ``yes=True``)."""
MAX_RUNS = 1_000_000
"""Runs one sweep may ask for at all (its plan is held in memory): split larger ones."""
IDENTITY = ("key", "scenario", "seed")
"""The columns that name a run (its swept values follow them)."""


@dataclass(frozen=True, slots=True)
class SweepRun:
    """One run of a sweep: its scenario (loaded with its values and seed) and what names it."""

    key: str
    """Hash of the scenario's name as given, the values and the seed: the same run in any sweep or resume."""
    label: str
    """The scenario as the sweep named it (bundled name or file)."""
    values: tuple[tuple[str, str], ...]
    """The swept ``--set`` keys and their YAML values."""
    seed: int
    scenario: Scenario

    def row(self) -> dict[str, Any]:
        """The columns that name this run: :data:`IDENTITY` and the swept values (as YAML reads them)."""
        return {"key": self.key, "scenario": self.label, "seed": self.seed,
                **{k: _value(v) for k, v in self.values if k != "seed"}}


def run_key(label: str, values: Sequence[tuple[str, str]], seed: int) -> str:
    """The stable key of a run (16 hex digits of a SHA-256)."""
    text = json.dumps([label, sorted(values), seed])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _value(text: str) -> Any:
    """A ``--set`` value as a table cell: numbers, booleans and words as YAML reads them, anything else as text."""
    try:
        v = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    return v if isinstance(v, bool | int | float | str) else text


def read_sweep(path: str | Path, yes: bool = False) -> list[SweepRun]:
    """The runs of the sweep file ``path``, every scenario loaded and checked (a bad one stops the sweep here).

    Raises:
        SpecError: an unknown key, a bad value or distribution (``file:line``), a scenario that does not load, or
            more than :data:`CONFIRM_RUNS` runs without ``yes`` (more than :data:`MAX_RUNS` at all).
    """
    data, src = read_yaml(Path(path))
    if not isinstance(data, Mapping):
        raise src.error((), "expected a mapping with scenarios (and grid, samples, seeds)")
    for k in data:
        if k not in KEYS:
            raise src.error((k,), f"unknown key{_suggest(str(k), dict.fromkeys(KEYS))}")
    if "scenarios" not in data:
        raise src.error((), "missing scenarios: name the scenario files, bundled names or folders to sweep")
    scenarios = _scenarios(data["scenarios"], src, Path(path).parent)
    grid = _grid(data.get("grid") or {}, src)
    samples = _samples(data.get("samples"), src)
    seeds = _seeds(data.get("seeds"), src)
    if seeds is not None and any(k == "seed" for k, _ in grid):
        raise src.error(("seeds",), "seed is in the grid too; give the seeds in one place")
    try:
        return plan_runs(scenarios, grid, samples, seeds, yes)
    except SpecError as e:  # a scenario that does not load with some values: where the sweep asked for them
        raise SpecError(f"{_asked(str(e), src, grid, samples)}: {e}") from None


def _asked(error: str, src: Source, grid: Sequence[tuple[str, Sequence[str]]],
           samples: Sequence[Sequence[tuple[str, str]]]) -> str:
    """``file:line`` of the grid value or the sampled key whose ``--set`` ``error`` names, else the file."""
    for k, values in grid:
        for i, v in enumerate(values):
            if error.startswith(f"--set {k}={v}: "):
                return src.where(("grid", k, i))
    for k, _ in samples[0]:
        if error.startswith(f"--set {k}="):
            return src.where(("samples", "values", k))
    return src.name


def plan_runs(scenarios: Sequence[str], grid: Sequence[tuple[str, Sequence[str]]],
              samples: Sequence[Sequence[tuple[str, str]]] = ((),), seeds: Sequence[int] | None = None,
              yes: bool = False) -> list[SweepRun]:
    """Every combination of a scenario, a grid point (``grid``: each key's YAML values), a sample and a seed
    (``None``: each scenario's own), loaded and checked, each once; see :func:`read_sweep` for the errors."""
    if seeds is not None and any(k == "seed" for k, _ in grid):
        raise SpecError("sweep: seed is in the grid and in seeds; give the seeds in one place")
    total = len(scenarios) * math.prod(len(v) for _, v in grid) * len(samples) * (len(seeds) if seeds else 1)
    if total > MAX_RUNS:
        raise SpecError(f"sweep: {total:.3g} runs, more than {MAX_RUNS} in one sweep; split it into smaller sweeps")
    if total > CONFIRM_RUNS and not yes:
        raise SpecError(f"sweep: {total} runs, more than {CONFIRM_RUNS}; give --yes to run them all")
    runs: dict[str, SweepRun] = {}  # by key: a run asked for twice (a value given twice, a draw repeated) runs once
    for label in scenarios:
        for point in itertools.product(*([(k, v) for v in vs] for k, vs in grid)):
            for sample in samples:
                values = (*point, *sample)
                scenario = load_scenario(label, dict(values))
                for seed in seeds if seeds is not None else (scenario.sim.seed,):
                    s = dataclasses.replace(scenario, sim=dataclasses.replace(scenario.sim, seed=seed))
                    key = run_key(label, values, seed)
                    runs.setdefault(key, SweepRun(key, label, values, seed, s))
    return list(runs.values())


def _scenarios(raw: Any, src: Source, here: Path) -> list[str]:
    """Scenario names and files as given (relative to the sweep file), a folder as its .yaml and .xml files."""
    items = [raw] if isinstance(raw, str) else raw
    if not isinstance(items, list) or not items or not all(isinstance(i, str) for i in items):
        raise src.error(("scenarios",), "expected a scenario file, bundled name or folder, or a list of them")
    out = []
    for i, item in enumerate(items):
        p = here / item
        if p.is_dir():
            found = sorted(str(f) for f in p.iterdir() if f.suffix in (".yaml", ".xml"))
            if not found:
                raise src.error(("scenarios", i), f"folder {p} holds no .yaml or .xml scenario")
            out += found
        else:
            out.append(str(p) if p.is_file() else item)
    return out


def _grid(raw: Any, src: Source) -> list[tuple[str, list[str]]]:
    """``key: [values]`` (a sweep) or ``key: value`` (fixed), each value as YAML text."""
    if not isinstance(raw, Mapping):
        raise src.error(("grid",), "expected a mapping of --set keys to a value or a list of values")
    out = []
    for k, v in raw.items():
        values = v if isinstance(v, list) else [v]
        if not values:
            raise src.error(("grid", k), "an empty list sweeps nothing; give at least one value")
        out.append((str(k), [json.dumps(x) for x in values]))
    return out


def _samples(raw: Any, src: Source) -> list[tuple[tuple[str, str], ...]]:
    """``count`` draws of ``values`` (a distribution a key) from a generator seeded with ``seed``."""
    if raw is None:
        return [()]
    if not isinstance(raw, Mapping):
        raise src.error(("samples",), "expected a mapping with count, seed and values")
    for k in raw:
        if k not in SAMPLE_KEYS:
            raise src.error(("samples", k), f"unknown key{_suggest(str(k), dict.fromkeys(SAMPLE_KEYS))}")
    count, seed, values = raw.get("count"), raw.get("seed", 0), raw.get("values")
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise src.error(("samples", "count"), f"expected a whole number of draws >= 1, got {count!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise src.error(("samples", "seed"), f"expected a whole number >= 0, got {seed!r}")
    if not isinstance(values, Mapping) or not values:
        raise src.error(("samples", "values"), "expected a mapping of --set keys to distributions, e.g. "
                                               "task.speed: {uniform: [5, 10]}")
    draws = {k: _distribution(v, src, ("samples", "values", k)) for k, v in values.items()}
    rng = np.random.default_rng(seed)
    out = [tuple((k, draw(rng, args)) for k, (draw, args) in draws.items()) for _ in range(count)]
    for k, v in itertools.chain.from_iterable(out):
        if isinstance(v, float) and not math.isfinite(v):  # a normal's draw past the largest float
            raise src.error(("samples", "values", k), f"drew {v}, not a finite number; narrow the distribution")
    return [tuple((str(k), json.dumps(v)) for k, v in sample) for sample in out]


def _distribution(raw: Any, src: Source, key: tuple) -> tuple:
    """``{name: [arguments]}`` as (its draw, its arguments)."""
    if not isinstance(raw, Mapping) or len(raw) != 1:
        raise src.error(key, f"expected one distribution, e.g. {{uniform: [0, 1]}}; known: {', '.join(DISTRIBUTIONS)}")
    (name, args), = raw.items()
    if name not in DISTRIBUTIONS:
        raise src.error((*key, name), f"unknown distribution{_suggest(str(name), DISTRIBUTIONS)}")
    shape, draw = DISTRIBUTIONS[name]
    if name == "choice":
        ok = isinstance(args, list) and len(args) > 0 and all(_finite(a) for a in args if isinstance(a, int | float))
    else:  # numbers a float holds; numpy's uniform also refuses a high - low past the largest float
        ok = isinstance(args, list) and len(args) == 2 and all(_finite(a) and not isinstance(a, bool) for a in args)
        if ok:
            a, b = args
            ok = math.copysign(1.0, b) > 0 if name == "normal" else (  # (numpy refuses a std of -0.0 too)
                a < b and _finite(b - a) and (name == "uniform" or a > 0))
    if not ok:
        raise src.error((*key, name), f"expected {shape}, got {args!r}")
    return draw, args


def _finite(a: Any) -> bool:
    """Whether ``a`` is a number a float holds (not NaN, not infinite, not an int past the largest float)."""
    return isinstance(a, int | float) and abs(a) <= sys.float_info.max


def _seeds(raw: Any, src: Source) -> list[int] | None:
    """``N`` (seeds 0 to N - 1) or a list of seeds; ``None`` without ``seeds`` (each scenario's own)."""
    if raw is None:
        return None
    ok = (isinstance(raw, int) and not isinstance(raw, bool) and raw >= 1) or (
        isinstance(raw, list) and raw and all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in raw)
        and len(set(raw)) == len(raw))
    if not ok:
        raise src.error(("seeds",), f"expected a count of seeds >= 1 or a list of different seeds >= 0, got {raw!r}")
    return list(range(raw)) if isinstance(raw, int) else raw


def plan_sets(scenarios: Sequence[str], sets: Sequence[str], yes: bool = False) -> list[SweepRun]:
    """The runs of ``vilma run SCENARIO... --set ...`` (``key=a,b`` sweeps, as :func:`~vilma.app.batch.parse_sets`)."""
    points = parse_sets(sets)
    grid = [(k, list(dict.fromkeys(p[k] for p in points))) for k in points[0]]
    return plan_runs(scenarios, grid, yes=yes)
