"""YAML with lines onto dataclasses: every bad input is one located line."""

from __future__ import annotations

from dataclasses import dataclass

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.scenario.fields import SpecError, build, load_yaml


@dataclass(frozen=True, slots=True, kw_only=True)
class Inner:
    gain: float = 1.0
    count: int = 2

    def __post_init__(self) -> None:
        if self.gain < 0:
            raise ValueError(f"gain must be >= 0, got {self.gain}")


@dataclass(frozen=True, slots=True, kw_only=True)
class Outer:
    name: str
    inner: Inner = Inner()
    maybe: Inner | None = None
    pair: tuple[float, float] = (0.0, 0.0)
    enabled: bool = False


def _build(text: str):
    data, src = load_yaml(text, "f.yaml")
    return build(Outer, data, src)


def test_values_defaults_and_merging():
    o = _build("name: a\ninner: {count: 5}\nmaybe: true\npair: [1, 2.5]\nenabled: true\n")
    assert o == Outer(name="a", inner=Inner(count=5), maybe=Inner(), pair=(1.0, 2.5), enabled=True)
    assert _build("name: a\nmaybe: false\n").maybe is None
    base = Outer(name="b", inner=Inner(gain=3.0))
    data, src = load_yaml("inner: {count: 7}", "f.yaml")
    assert build(Outer, data, src, base=base).inner == Inner(gain=3.0, count=7)  # merged onto the base


@pytest.mark.parametrize(("text", "message"), [
    ("name: a\ninner:\n  gian: 2\n", "f.yaml:3: inner.gian: unknown key; did you mean 'gain'?"),
    ("name: a\ninner:\n  gain: -1\n", "f.yaml:2: inner: gain must be >= 0, got -1.0"),
    ("name: a\ninner: {gain: .nan}\n", "f.yaml:2: inner.gain: expected a finite number, got nan"),
    ("name: a\ninner: {count: 1.5}\n", "f.yaml:2: inner.count: expected a whole number, got 1.5"),
    ("name: a\nenabled: yes please\n", "f.yaml:2: enabled: expected true or false, got 'yes please'"),
    ("name: a\n3: 4\n", "f.yaml:1: key 3 is not a name"),
    ("name: a\npair: [1, 2, 3]\n", "f.yaml:2: pair: expected a list of 2 values, got 3"),
    ("name: a\npair: [1, x]\n", "f.yaml:2: pair[1]: expected a number, got 'x'"),
    ("inner: {}\n", "f.yaml:1: missing name"),
    ("name: a\nname: b\n", "f.yaml:2: name: given twice; keep one"),
    ("name: [a\n", "f.yaml:2: not valid YAML"),
    ("- 1\n- 2\n", "f.yaml:1: expected a mapping of Outer fields, got a list"),
    ("name: a\ninner: 3\n", "f.yaml:2: inner: expected a mapping of Inner fields, got 3"),
])
def test_errors_name_file_line_and_field(text, message):
    with pytest.raises(SpecError) as e:
        _build(text)
    assert str(e.value).startswith(message)
    assert "\n" not in str(e.value)


@given(st.text(max_size=200))
def test_any_text_parses_or_fails_cleanly(text):
    try:
        data, src = load_yaml(text, "f.yaml")
        build(Outer, data, src)
    except SpecError as e:
        assert str(e).startswith("f.yaml")


@given(st.dictionaries(st.sampled_from(["name", "inner", "maybe", "pair", "enabled", "x"]),
                       st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=5),
                                    lambda c: st.lists(c, max_size=3) | st.dictionaries(
                                        st.sampled_from(["gain", "count", "y"]), c, max_size=3), max_leaves=6)))
def test_any_mapping_builds_or_fails_cleanly(data):
    try:
        o = build(Outer, data, load_yaml("", "f.yaml")[1])
    except SpecError:
        return
    assert isinstance(o, Outer)
