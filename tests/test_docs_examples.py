"""The documentation's examples run and print what their pages say, and the README shows the same code.

A page shows an example file with a snippet include (``--8<-- "docs/examples/NAME.py"``) in a python block;
the ``text`` block right after it is what the example prints.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```$", re.MULTILINE | re.DOTALL)
INCLUDE = re.compile(r'^--8<-- "(docs/examples/[\w.]+\.py)"$', re.MULTILINE)


def shown_examples(text: str) -> list[tuple[str, str | None]]:
    """(example file, the output shown after it or None) for each example a page's text includes."""
    blocks = FENCE.findall(text)
    out = []
    for i, (lang, body) in enumerate(blocks):
        include = INCLUDE.search(body)
        if lang == "python" and include:
            after = blocks[i + 1] if i + 1 < len(blocks) else None
            out.append((include.group(1), after[1] if after and after[0] == "text" else None))
    return out


EXAMPLES = [(page.relative_to(ROOT).as_posix(), example, output)
            for page in sorted(DOCS.rglob("*.md")) for example, output in shown_examples(page.read_text())]


def code_of(example: Path) -> str:
    """An example file's code without its module docstring."""
    text = example.read_text()
    return text[text.index('"""', 3) + 3:].lstrip("\n")


def test_the_parser_pairs_an_include_with_the_text_block_after_it():
    page = ('Intro\n\n```python\n--8<-- "docs/examples/a.py"\n```\n\nIt prints:\n\n```text\nx: 1\n```\n\n'
            '```python\n--8<-- "docs/examples/b.py"\n```\n\n```python\nprint(2)\n```\n')
    assert shown_examples(page) == [("docs/examples/a.py", "x: 1\n"), ("docs/examples/b.py", None)]


def test_every_example_file_is_on_a_page_with_its_output():
    shown = {example for _, example, output in EXAMPLES if output is not None}
    files = {p.relative_to(ROOT).as_posix() for p in (DOCS / "examples").glob("*.py")}
    assert files and shown == files


@pytest.mark.slow
@pytest.mark.parametrize(("page", "example", "output"), EXAMPLES, ids=[f"{p}:{e}" for p, e, _ in EXAMPLES])
def test_example_prints_what_its_page_says(page, example, output, tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / example)], cwd=tmp_path, capture_output=True, text=True,
                       timeout=600)  # generous: the first run compiles the driver (about a minute)
    assert r.returncode == 0, r.stderr
    assert r.stdout == output, f"{page} says {example} prints {output!r}"


def test_readme_library_example_is_the_tested_one():
    """The README's autonomous-functions example is docs/examples/follow_path.py, which the test above runs."""
    blocks = [body for lang, body in FENCE.findall((ROOT / "README.md").read_text())
              if lang == "python" and "driver.follow(" in body]
    assert blocks == [code_of(DOCS / "examples" / "follow_path.py")]


def test_api_pages_show_sphinx_roles_as_code():
    spec = importlib.util.spec_from_file_location("griffe_roles", DOCS / "griffe_roles.py")
    roles = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(roles)
    text = "Runs :class:`~vilma.sim.Simulator` and :func:`vilma.trajectory.densify` (see :mod:`vilma.bus`)::\n"
    assert roles.markdown(text) == "Runs `Simulator` and `vilma.trajectory.densify` (see `vilma.bus`):\n"
