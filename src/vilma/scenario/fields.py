"""YAML with line numbers, mapped onto frozen parameter dataclasses with precise errors.

Every parameter in vilma is a frozen dataclass with typed fields and checks in
``__post_init__``; a scenario file is those same fields written as YAML. This
module reads the YAML keeping each value's line, then builds the dataclasses
field by field: unknown keys, wrong types and values the dataclass refuses
become one :class:`SpecError` line, ``file:line: field.path: what (how to fix)``.

Every YAML file vilma reads (scenarios, vehicle parameter files, Zenoh configs, the scenario in a
recording, ``--set`` values) goes through :func:`load_yaml`, which refuses a document larger than
:data:`MAX_YAML_SIZE`, nested deeper than :data:`MAX_YAML_DEPTH` or holding more than
:data:`MAX_YAML_VALUES` values once its aliases are expanded (a "billion laughs" bomb), while composing it.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import sys
import types
import typing
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

MAX_YAML_SIZE = 1 << 20
"""Largest YAML document [characters; bytes of a file]: a scenario is a few kB (long paths go in a
``follow`` file), a scenario saved by the GUI with a 20,000-point table about 1 MB."""
MAX_YAML_DEPTH = 64
"""Deepest nesting of lists and mappings (a scenario nests 6 deep), within Python's recursion limit."""
MAX_YAML_VALUES = 100_000
"""Most values (scalars, lists, mappings) in a document with every alias expanded where it is used."""

Key = tuple[str | int, ...]
"""Where a value sits in the document: the keys and list indices leading to it."""


class SpecError(ValueError):
    """A bad scenario or parameter file: one line saying what, where and how to fix it."""


@dataclass(frozen=True, slots=True)
class Source:
    """Where a document came from and the line of each value in it (1-based)."""

    name: str
    lines: Mapping[Key, int | str]
    """Line numbers; a value set elsewhere (on the command line) has the text that set it instead."""

    def where(self, key: Key) -> str:
        """``file:line`` of ``key``, or of its nearest enclosing value that has a line."""
        for n in range(len(key), -1, -1):
            line = self.lines.get(key[:n])
            if isinstance(line, str):
                return line
            if line is not None:
                return f"{self.name}:{line}"
        return self.name

    def error(self, key: Key, message: str) -> SpecError:
        """A :class:`SpecError` located at ``key`` (and the ``--set`` values within it that it may come from)."""
        field, where = dotted(key), self.where(key)
        sets = [v for k, v in self.lines.items() if isinstance(v, str) and len(k) > len(key) and k[:len(key)] == key]
        if sets and where not in sets:
            where += f" ({', '.join(sets)})"
        return SpecError(f"{where}: {field + ': ' if field else ''}{message}")


def dotted(key: Key) -> str:
    """``task.points[2]`` for ``("task", "points", 2)``."""
    out = ""
    for k in key:
        out += f"[{k}]" if isinstance(k, int) else (f".{k}" if out else str(k))
    return out


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader, bounded: it counts the values and the depth of the document as it composes it,
    an alias counting as everything its anchor holds, and stops at :data:`MAX_YAML_DEPTH` or
    :data:`MAX_YAML_VALUES`. Numbers with an exponent but no dot (``1e9``) are floats, as in YAML 1.2."""

    def __init__(self, text: str, name: str) -> None:
        super().__init__(text)
        self.name = name
        self._depth = 0  # of the node being composed (the document's root is 1)
        self._deepest = 0  # the deepest level reached inside it so far, aliases expanded
        self._values = 0  # values so far, aliases expanded
        self._anchored: dict[str, tuple[int, int]] = {}  # anchor -> (values, levels) of its node

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent):
            node = super().compose_node(parent, index)  # its anchor's node (an undefined one is an error)
            if event.anchor not in self._anchored:
                raise self._error(event, f"alias *{event.anchor} inside its own anchor: a value cannot hold itself")
            values, levels = self._anchored[event.anchor]
            self._count(event, values, self._depth + levels)
            return node
        self._depth += 1
        outer, start = self._deepest, self._values
        self._deepest = 0
        self._count(event, 1, self._depth)
        node = super().compose_node(parent, index)
        if event.anchor is not None:
            self._anchored[event.anchor] = (self._values - start, self._deepest - self._depth + 1)
        self._deepest = max(outer, self._deepest)
        self._depth -= 1
        return node

    def _count(self, event: yaml.Event, values: int, depth: int) -> None:
        """Add ``values`` reaching down to level ``depth`` at ``event``; raise beyond the limits."""
        self._values += values
        self._deepest = max(self._deepest, depth)
        if depth > MAX_YAML_DEPTH:
            raise self._error(event, f"nested more than {MAX_YAML_DEPTH} levels deep, the limit of a YAML file; "
                                     "flatten it")
        if self._values > MAX_YAML_VALUES:
            raise self._error(event, f"more than {MAX_YAML_VALUES} values with its aliases expanded, the limit of a "
                                     "YAML file; use fewer aliases and values (long paths go in a follow file)")

    def _error(self, event: yaml.Event, message: str) -> SpecError:
        return SpecError(f"{self.name}:{event.start_mark.line + 1}: {message}")


_EXPONENT_FLOAT = re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$")
"""``1e9``, ``2.5E-3``: floats in YAML 1.2, text in PyYAML's YAML 1.1 (which wants a dot and a signed exponent)."""
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+0123456789"))


def _too_large(name: str) -> SpecError:
    return SpecError(f"{name}: larger than {MAX_YAML_SIZE >> 20} MiB, the limit of a YAML file; a scenario is a few "
                     "kB (long paths go in a follow file)")


def load_yaml(text: str, name: str) -> tuple[Any, Source]:
    """Parse YAML ``text`` (from file ``name``) into plain values and the line of each; duplicate keys are errors,
    and so are documents beyond :data:`MAX_YAML_SIZE`, :data:`MAX_YAML_DEPTH` or :data:`MAX_YAML_VALUES`."""
    if len(text) > MAX_YAML_SIZE:
        raise _too_large(name)
    try:
        loader = _Loader(text, name)
        try:
            node = loader.get_single_node()
            data = loader.construct_document(node) if node is not None else None
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        line = f":{mark.line + 1}" if mark else ""
        raise SpecError(f"{name}{line}: not valid YAML: {e.problem or e.context}") from None
    except yaml.reader.ReaderError as e:  # a control character
        c = chr(e.character) if isinstance(e.character, int) else e.character
        raise SpecError(f"{name}:{text.count(chr(10), 0, e.position) + 1}: not valid YAML: the character {c!r} is "
                        "not allowed; remove it") from None
    except yaml.YAMLError as e:
        raise SpecError(f"{name}: not valid YAML: {' '.join(str(e).split())}") from None
    except SpecError:  # the loader's own limits
        raise
    except ValueError:  # PyYAML's int() of a number longer than Python converts
        raise SpecError(f"{name}: a number of more than {sys.get_int_max_str_digits()} digits; no value needs that "
                        "many") from None
    lines: dict[Key, int] = {}
    if node is not None:
        _collect_lines(node, (), lines, name)
    return data, Source(name, lines)


def _collect_lines(node: yaml.Node, key: Key, lines: dict[Key, int], name: str) -> None:
    lines[key] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        seen: set[str] = set()
        for k, v in node.value:
            if not isinstance(k, yaml.ScalarNode):
                raise SpecError(f"{name}:{k.start_mark.line + 1}: a key must be a plain word")
            if k.value in seen:
                raise SpecError(f"{name}:{k.start_mark.line + 1}: {dotted((*key, k.value))}: given twice; keep one")
            seen.add(k.value)
            _collect_lines(v, (*key, k.value), lines, name)
            lines[(*key, k.value)] = k.start_mark.line + 1
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _collect_lines(v, (*key, i), lines, name)


def read_yaml(path: Path) -> tuple[Any, Source]:
    """:func:`load_yaml` of a file; a missing, unreadable or too large file is a :class:`SpecError`."""
    try:
        with path.open("rb") as f:
            raw = f.read(MAX_YAML_SIZE + 1)  # no more: a huge file or /dev/zero is refused, not read
    except FileNotFoundError:
        raise SpecError(f"{path}: no such file") from None
    except OSError as e:
        raise SpecError(f"{path}: cannot read: {e.strerror}") from None
    if len(raw) > MAX_YAML_SIZE:
        raise _too_large(str(path))
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise SpecError(f"{path}: not a text file (expected UTF-8 YAML)") from None
    return load_yaml(text, str(path))


def build(cls: type, data: Any, src: Source, key: Key = (), base: Any = None, others: tuple[str, ...] = ()) -> Any:
    """An instance of the frozen dataclass ``cls`` from the mapping ``data`` at ``key``.

    Fields not given keep their value in ``base`` (an instance of ``cls``), or ``cls``'s defaults.
    A nested dataclass field takes a mapping (merged onto its current value); a field typed
    ``X | None`` with a dataclass ``X`` also takes ``true`` (``X``'s defaults) and ``false`` (None). The keys
    ``others`` are read elsewhere: skipped here, and named among the known keys when a key is unknown.
    """
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise src.error(key, f"expected a mapping of {cls.__name__} fields, got {_shown(data)}")
    fields, hints = _schema(cls)
    values = {}
    for name, value in data.items():
        if not isinstance(name, str):
            raise src.error(key, f"key {name!r} is not a name (YAML reads on/off/yes/no as true/false: quote it)")
        k = (*key, name)
        if name in others:
            continue
        if name not in fields:
            raise src.error(k, f"unknown key{_suggest(str(name), [*fields, *others])}")
        current = getattr(base, name) if base is not None else _default(fields[name])
        values[name] = convert(hints[name], value, src, k, current)
    try:
        return dataclasses.replace(base, **values) if base is not None else cls(**values)
    except TypeError as e:  # a required field is missing
        missing = [n for n, f in fields.items() if n not in values and _default(f) is dataclasses.MISSING]
        if missing:
            raise src.error(key, f"missing {', '.join(missing)}") from None
        raise src.error(key, str(e)) from None
    except ValueError as e:  # located at the field it names first, if one was given, else at the mapping
        named = [(m.start(), n) for n in values if (m := re.search(rf"\b{n}\b", str(e)))]
        raise src.error((*key, min(named)[1]) if named else key, str(e)) from None


@functools.cache
def _schema(cls: type) -> tuple[dict[str, dataclasses.Field], dict[str, Any]]:
    """The fields ``cls`` takes, by name, and their types: resolved once a class (a sweep loads a scenario a run)."""
    return {f.name: f for f in dataclasses.fields(cls) if f.init}, typing.get_type_hints(cls)


def get(data: Mapping, src: Source, key: Key, hint: Any, default: Any = None) -> Any:
    """The value at ``key`` (its last part a key of the mapping ``data``) checked against the type ``hint``, or
    ``default`` if ``data`` has none."""
    return convert(hint, data[key[-1]], src, key, default) if key[-1] in data else default


def _default(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def convert(hint: Any, value: Any, src: Source, key: Key, current: Any = None) -> Any:
    """``value`` checked against the type ``hint``; ``current`` is the value it replaces (for merging)."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        options = [a for a in args if a is not type(None)]
        if value is None and len(options) < len(args):
            return None
        if len(options) == 1 and dataclasses.is_dataclass(options[0]) and isinstance(value, bool):
            return options[0]() if value else None
        errors = []
        for option in options:
            try:
                return convert(option, value, src, key, current)
            except SpecError as e:
                errors.append(e)
        raise errors[-1]
    if dataclasses.is_dataclass(hint):
        base = current if isinstance(current, hint) else None
        return build(hint, value, src, key, base)
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise src.error(key, f"expected a list, got {_shown(value)}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(convert(args[0], v, src, (*key, i)) for i, v in enumerate(value))
        if len(value) != len(args):
            raise src.error(key, f"expected a list of {len(args)} values, got {len(value)}")
        return tuple(convert(a, v, src, (*key, i)) for i, (a, v) in enumerate(zip(args, value, strict=True)))
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise src.error(key, f"expected a number, got {_shown(value)}")
        if not math.isfinite(value):
            raise src.error(key, f"expected a finite number, got {value}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise src.error(key, f"expected a whole number, got {_shown(value)}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise src.error(key, f"expected true or false, got {_shown(value)}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise src.error(key, f"expected text, got {_shown(value)}")
        return value
    if hint is Any:
        return value
    raise TypeError(f"{dotted(key)}: fields of type {hint!r} cannot be read from YAML")  # a bug in vilma


def _shown(value: Any) -> str:
    if isinstance(value, Mapping):
        return "a mapping"
    if isinstance(value, list):
        return "a list"
    return f"{value!r}" if value is not None else "nothing (null)"


def _suggest(name: str, known: Iterable[str]) -> str:
    import difflib  # on a mistake only

    close = difflib.get_close_matches(name, list(known), n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return f"{hint} (known: {', '.join(known)})"
