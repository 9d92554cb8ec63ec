"""The bundled scenarios: found by name, described in a line, loaded by name as the command line does."""

from __future__ import annotations

import pytest
import yaml

from vilma.scenario import SpecError, load_scenario
from vilma.scenario.bundled import BUNDLED, find_scenario, names, summary


def test_names_are_the_bundled_files():
    assert names() == sorted(p.name.removesuffix(".yaml") for p in BUNDLED.iterdir() if p.suffix == ".yaml")
    assert "course_30kmh_stanley" in names() and "paper_fig11_speed_10" in names()


def test_load_scenario_takes_a_bundled_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no file of that name here: the bundled one
    by_name = load_scenario("course_30kmh_stanley")
    assert by_name.file == BUNDLED / "course_30kmh_stanley.yaml"
    assert by_name == load_scenario(BUNDLED / "course_30kmh_stanley.yaml")
    (tmp_path / "course_30kmh_stanley.yaml").write_text("task: {speed: 3}\n")  # a file of that name wins
    assert load_scenario("course_30kmh_stanley.yaml").task.speed == 3


def test_an_unknown_name_lists_the_bundled_ones(tmp_path):
    with pytest.raises(SpecError) as e:
        load_scenario("no_such_scenario")
    assert str(e.value).startswith("no_such_scenario: no such file, nor a bundled scenario (bundled: ")
    assert all(n in str(e.value) for n in names()) and "\n" not in str(e.value)
    with pytest.raises(SpecError, match="no such file"):
        find_scenario(tmp_path / "course_30kmh_stanley.yaml")  # a path is a file, never a bundled name
    with pytest.raises(SpecError, match=r"^course_30kmh_stanly: no such file, nor a bundled scenario \(did you mean "
                                        r"'course_30kmh_stanley'\? bundled: "):
        find_scenario("course_30kmh_stanly")


@pytest.mark.parametrize("name", names())
def test_summary_is_the_first_sentence_of_the_description(name):
    path = BUNDLED / f"{name}.yaml"
    description = " ".join(yaml.safe_load(path.read_text())["description"].split())
    line = summary(path)
    assert line and description.startswith(line) and line.endswith(".")
    rest = description[len(line):]
    assert rest == "" or (rest[0] == " " and (rest[1].isupper() or rest[1] == "("))  # cut where a sentence ends


def test_summary_without_description(tmp_path):
    p = tmp_path / "bare.yaml"
    p.write_text("task: {speed: 1}\n")
    assert summary(p) == ""
