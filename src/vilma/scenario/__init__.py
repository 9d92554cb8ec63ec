"""Scenarios: files that describe a drive, the runner that drives them headless, the scorecard and the report."""

from vilma.scenario.fields import SpecError
from vilma.scenario.spec import SCORECARD_KEYS, Bound, Scenario, TaskSpec, load_scenario, parse_scenario, to_yaml

__all__ = ["SCORECARD_KEYS", "Bound", "Scenario", "SpecError", "TaskSpec", "load_scenario", "parse_scenario",
           "to_yaml"]
