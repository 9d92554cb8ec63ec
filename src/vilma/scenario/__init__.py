"""Scenarios: files that describe a drive, the runner that drives them headless, the scorecard and the report.

The names below load on first use (PEP 562): a module of the package (the drive log, say) can be imported
without the scenario files' parser and what it brings in (the driver, scipy).
"""

from importlib import import_module

_EXPORTS = {"SpecError": "vilma.scenario.fields", **dict.fromkeys(
    ("SCORECARD_KEYS", "Bound", "Scenario", "TaskSpec", "load_scenario", "parse_scenario", "to_yaml"),
    "vilma.scenario.spec")}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(_EXPORTS[name]), name)
