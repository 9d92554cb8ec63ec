"""The scenarios that come with vilma: their names, their files and a line about each.

Light on purpose (no scenario parser, no numba): the command line names them in its help.
"""

from __future__ import annotations

import re
from pathlib import Path

BUNDLED = Path(__file__).resolve().parent.parent / "scenarios"
"""The scenarios that come with vilma (``src/vilma/scenarios/`` in a clone, inside the installed package)."""

_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z(])")


def names() -> list[str]:
    """The bundled scenarios' names (their file stems), sorted."""
    return sorted(p.stem for p in BUNDLED.glob("*.yaml"))


def find_scenario(name: str | Path) -> Path:
    """The file ``name``, else the bundled scenario of that name (with or without ``.yaml``).

    Raises:
        SpecError: neither exists (the message lists the bundled names).
    """
    path = Path(name)
    if path.exists():
        return path
    bundled = BUNDLED / (path.name if path.suffix == ".yaml" else f"{path.name}.yaml")
    if not path.parent.parts and bundled.is_file():
        return bundled
    import difflib  # on a mistake only

    from vilma.scenario.fields import SpecError

    close = difflib.get_close_matches(path.stem, names(), n=1) if not path.parent.parts else []
    hint = f"did you mean {close[0]!r}? " if close else ""
    raise SpecError(f"{name}: no such file, nor a bundled scenario ({hint}bundled: {', '.join(names())}; "
                    "`vilma scenarios` describes them)")


def summary(path: Path) -> str:
    """The first sentence of the scenario file's ``description`` (empty if it has none)."""
    from vilma.scenario.fields import read_yaml

    data, _ = read_yaml(path)
    text = " ".join(str(data.get("description") or "").split()) if isinstance(data, dict) else ""
    return _SENTENCE_END.split(text, maxsplit=1)[0]
