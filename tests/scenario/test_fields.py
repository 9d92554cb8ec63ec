"""YAML with lines onto dataclasses: every bad input is one located line."""

from __future__ import annotations

import ast
import subprocess
import sys
from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vilma.scenario.fields import (
    MAX_YAML_DEPTH,
    MAX_YAML_SIZE,
    MAX_YAML_VALUES,
    SpecError,
    build,
    get,
    load_yaml,
    read_yaml,
)


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
    ("name: a\ninner:\n  gain: -1\n", "f.yaml:3: inner.gain: gain must be >= 0, got -1.0"),
    ("name: a\ninner: {gain: .nan}\n", "f.yaml:2: inner.gain: expected a finite number, got nan"),
    ("name: a\ninner: {count: 1.5}\n", "f.yaml:2: inner.count: expected a whole number, got 1.5"),
    ("name: a\nenabled: yes please\n", "f.yaml:2: enabled: expected true or false, got 'yes please'"),
    ("name: a\n3: 4\n", "f.yaml:1: key 3 is not a name"),
    ("name: a\npair: [1, 2, 3]\n", "f.yaml:2: pair: expected a list of 2 values, got 3"),
    ("name: a\npair: [1, x]\n", "f.yaml:2: pair[1]: expected a number, got 'x'"),
    ("inner: {}\n", "f.yaml:1: missing name"),
    ("name: a\nname: b\n", "f.yaml:2: name: given twice; keep one"),
    ("name: [a\n", "f.yaml:2: not valid YAML"),
    ("name: a\ninner: {count: 1\x00}\n", "f.yaml:2: not valid YAML: the character '\\x00' is not allowed"),
    (f"name: a\ninner: {{count: {'9' * 5000}}}\n", "f.yaml: a number of more than 4300 digits"),
    ("- 1\n- 2\n", "f.yaml:1: expected a mapping of Outer fields, got a list"),
    ("name: a\ninner: 3\n", "f.yaml:2: inner: expected a mapping of Inner fields, got 3"),
])
def test_errors_name_file_line_and_field(text, message):
    with pytest.raises(SpecError) as e:
        _build(text)
    assert str(e.value).startswith(message)
    assert "\n" not in str(e.value)


def test_get_reads_one_value_checked_on_its_line_or_gives_the_default():
    data, src = load_yaml("a:\n  step: 1\n  name: x\n", "f.yaml")
    step = get(data["a"], src, ("a", "step"), float, 0.5)
    assert step == 1.0 and isinstance(step, float)  # YAML's integer 1, as the number the hint asks for
    assert get(data["a"], src, ("a", "seed"), int, 7) == 7
    with pytest.raises(SpecError, match=r"^f\.yaml:3: a\.name: expected a number, got 'x'$"):
        get(data["a"], src, ("a", "name"), float)


def test_the_generic_readers_import_nothing_of_vilma_above_them():
    """Imports flow one way: scenario.spec uses fields, never the reverse (nor anything else of vilma)."""
    code = ("import sys, vilma; before = set(sys.modules); import vilma.scenario.fields; "
            "print(sorted(m for m in set(sys.modules) - before if m.startswith('vilma')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300)
    assert ast.literal_eval(out.stdout) == ["vilma.scenario", "vilma.scenario.fields"]  # (beyond vilma's own start)


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


# -- limits: every YAML vilma reads is bounded in size, depth and values (aliases expanded) ---------------------


def _nested(depth: int, kind: str) -> tuple[str, object]:
    """A document ``depth`` levels deep (its innermost scalar included) in one of three styles, and its value."""
    value: object = 1
    for _ in range(depth - 1):
        value = [value] if kind == "flow list" else {"a": value}
    if kind == "flow list":
        return "[" * (depth - 1) + "1" + "]" * (depth - 1), value
    if kind == "flow mapping":
        return "{a: " * (depth - 1) + "1" + "}" * (depth - 1), value
    lines = ["  " * i + "a:" for i in range(depth - 1)]
    return "\n".join([*lines[:-1], lines[-1] + " 1"]) if lines else "1", value


def _refused(text: str, limit: str) -> None:
    with pytest.raises(SpecError) as e:
        load_yaml(text, "f.yaml")
    assert str(e.value).startswith("f.yaml:") and limit in str(e.value) and "\n" not in str(e.value)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 3 * MAX_YAML_DEPTH), st.sampled_from(["flow list", "flow mapping", "block mapping"]))
def test_nesting_is_parsed_up_to_the_depth_limit_and_refused_beyond(depth, kind):
    text, value = _nested(depth, kind)
    if depth <= MAX_YAML_DEPTH:
        assert load_yaml(text, "f.yaml")[0] == value
    else:
        _refused(text, f"nested more than {MAX_YAML_DEPTH} levels deep")


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 12), st.integers(1, 12))
def test_alias_chains_are_parsed_up_to_the_value_limit_and_refused_beyond(levels, fan_out):
    """``a0: &a0 [x, x ..]``, ``a1: &a1 [*a0, *a0 ..]``...: each level holds ``fan_out`` of the one before."""
    lines = [f"a0: &a0 [{', '.join(['x'] * fan_out)}]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * fan_out)}]" for i in range(1, levels)]
    sizes = [1 + fan_out]  # values each anchor expands to: its list and what it holds
    for _ in range(1, levels):
        sizes.append(1 + fan_out * sizes[-1])
    values = 1 + sum(1 + size for size in sizes)  # the root mapping, each key and its list
    if values <= MAX_YAML_VALUES:  # levels + 2 deep at most: within the depth limit
        expected = {}
        inner: object = "x"
        for i in range(levels):
            inner = [inner] * fan_out
            expected[f"a{i}"] = inner
        assert load_yaml("\n".join(lines), "f.yaml")[0] == expected
    else:
        _refused("\n".join(lines), f"more than {MAX_YAML_VALUES} values with its aliases expanded")


@settings(max_examples=60, deadline=None)
@given(st.integers(1, MAX_YAML_DEPTH), st.integers(0, MAX_YAML_DEPTH))
def test_an_alias_is_as_deep_as_its_anchor_where_it_is_used(anchor_depth, used_at):
    """``a: &a [[..]]`` (``anchor_depth`` lists) used inside ``used_at`` lists reaches ``1 + used_at +
    anchor_depth`` levels from the root mapping."""
    anchored, value = "[" * anchor_depth + "]" * anchor_depth, []
    for _ in range(anchor_depth - 1):
        value = [value]
    used = value
    for _ in range(used_at):
        used = [used]
    text = f"a: &a {anchored}\nb: {'[' * used_at}*a{']' * used_at}"
    if 1 + used_at + anchor_depth <= MAX_YAML_DEPTH:
        assert load_yaml(text, "f.yaml")[0] == {"a": value, "b": used}
    else:
        _refused(text, f"nested more than {MAX_YAML_DEPTH} levels deep")


def test_a_billion_laughs_and_a_loop_are_refused_on_their_line():
    lol = ['a0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    lol += [f"a{i}: &a{i} [{','.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]
    # a0..a4 hold 1 + 11 + 92 + 821 + 7382 + 66431 = 74738 values with the root, a5 alone 1 + 9 * 66430 more
    with pytest.raises(SpecError, match=rf"^f\.yaml:6: more than {MAX_YAML_VALUES} values"):
        load_yaml("\n".join(lol), "f.yaml")
    with pytest.raises(SpecError, match=r"^f\.yaml:2: alias \*a inside its own anchor"):
        load_yaml("x: 1\na: &a [1, *a]\n", "f.yaml")


def test_size_limit_on_text_and_files(tmp_path):
    _refused_size = f"larger than {MAX_YAML_SIZE >> 20} MiB, the limit of a YAML file"
    comment = "#" * (MAX_YAML_SIZE - len("\nname: a\n")) + "\nname: a\n"  # exactly at the limit
    assert load_yaml(comment, "f.yaml")[0] == {"name": "a"}
    with pytest.raises(SpecError, match=f"^f.yaml: {_refused_size}"):
        load_yaml(comment + " ", "f.yaml")
    big = tmp_path / "big.yaml"
    big.write_text(comment + " ")
    with pytest.raises(SpecError, match=f"big.yaml: {_refused_size}"):
        read_yaml(big)


def test_numbers_with_an_exponent_are_floats_as_in_yaml_1_2():
    data, _ = load_yaml("a: 1e9\nb: 2.5E-3\nc: -1e+2\nd: 12\ne: 1.5\nf: 1e\ng: e9\n", "f.yaml")
    assert data == {"a": 1e9, "b": 2.5e-3, "c": -100.0, "d": 12, "e": 1.5, "f": "1e", "g": "e9"}
    assert isinstance(data["d"], int)
