"""The house: imports flow down the layers of pyproject's import-linter contract, with no circles; small files
and functions."""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


def lint(src: Path, tmp_path: Path) -> subprocess.CompletedProcess:
    """``lint-imports`` with the project's contracts on the package in ``src`` (its cache kept in ``tmp_path``)."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    return subprocess.run([str(LINT), "--config", str(ROOT / "pyproject.toml"), "--cache-dir", str(tmp_path / "cache")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)


def test_the_package_keeps_its_layers_and_has_no_circles(tmp_path):
    out = lint(ROOT / "src", tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "2 kept, 0 broken" in out.stdout


@pytest.mark.parametrize(("module", "line", "broken"), [
    ("core/clock.py", "import vilma.app.cli", "vilma.core is not allowed to import vilma.app"),
    ("bus/topics.py", "import vilma.morse", "vilma.bus is not allowed to import vilma.morse"),
    ("scenario/fields.py", "import vilma.scenario.runner", "No cycles are allowed in vilma.scenario"),
])
def test_an_upward_import_or_a_circle_breaks_the_contract(tmp_path, module, line, broken):
    """A copy of the package with one bad import: the check fails and names it."""
    shutil.copytree(ROOT / "src" / "vilma", tmp_path / "src" / "vilma", ignore=shutil.ignore_patterns("__pycache__"))
    with (tmp_path / "src" / "vilma" / module).open("a") as f:
        f.write(f"\n{line}  # noqa\n")
    out = lint(tmp_path / "src", tmp_path)
    assert out.returncode == 1 and broken in out.stdout


MAX_FILE_LINES, MAX_FUNCTION_LINES = 500, 80


def test_no_file_over_500_lines_and_no_function_over_80():
    too_long = []
    for path in sorted((ROOT / "src" / "vilma").rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        name = path.relative_to(ROOT)
        if len(text.splitlines()) > MAX_FILE_LINES:
            too_long.append(f"{name}: {len(text.splitlines())} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    too_long.append(f"{name}:{node.lineno} {node.name}: {lines} lines")
    assert not too_long, "split these: " + "; ".join(too_long)
