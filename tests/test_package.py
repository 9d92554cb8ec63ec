"""vilma as a package: ``python -m vilma``, shell completion, and what the wheel ships (licences, py.typed)."""

from __future__ import annotations

import ast
import glob
import importlib.metadata
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.specifiers import SpecifierSet
from packaging.utils import canonicalize_name
from packaging.version import Version

import vilma

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_the_version_has_one_source():
    # pyproject names vilma.__version__ as the version (dynamic), and setuptools reads it without importing vilma
    # only when it is a plain string literal assigned at the module's top
    project, setuptools = PYPROJECT["project"], PYPROJECT["tool"]["setuptools"]
    assert "version" not in project and "version" in project["dynamic"]
    assert setuptools["dynamic"]["version"] == {"attr": "vilma.__version__"}
    tree = ast.parse((ROOT / "src/vilma/__init__.py").read_text())
    (literal,) = [n.value.value for n in tree.body if isinstance(n, ast.Assign) and isinstance(n.value, ast.Constant)
                  and [t.id for t in n.targets if isinstance(t, ast.Name)] == ["__version__"]]
    assert literal == vilma.__version__ == str(Version(literal))  # PEP 440, in its normal form


def test_python_m_vilma_is_the_command():
    r = subprocess.run([sys.executable, "-m", "vilma", "--version"], capture_output=True, text=True, timeout=120)
    assert (r.returncode, r.stdout) == (0, f"vilma {vilma.__version__}\n")


def test_the_classifiers_agree_with_requires_python_the_licence_and_py_typed():
    project = PYPROJECT["project"]
    classifiers = project["classifiers"]
    supported = SpecifierSet(project["requires-python"])
    pythons = sorted(Version(c.rpartition(" :: ")[2]) for c in classifiers
                     if c.startswith("Programming Language :: Python :: 3."))
    assert pythons and all(v in supported for v in pythons)
    assert [Version(s.version) for s in supported if s.operator == ">="] == [pythons[0]]  # from the oldest on
    assert not any(s.operator in ("<", "<=") for s in supported)  # a cap makes pip pick an old release, or none
    # PEP 639: with an SPDX expression in `license`, a License :: classifier is an error for the build tools
    assert "license" in project and not [c for c in classifiers if c.startswith("License ::")]
    assert ("Typing :: Typed" in classifiers) == (ROOT / "src/vilma/py.typed").is_file()  # PEP 561's marker


CACHES = {".pyc", ".pyo", ".nbi", ".nbc"}
"""Python's and numba's compiled files: never shipped (they are made where the package is run)."""


def test_every_data_file_of_the_package_is_package_data():
    # the wheel holds the modules and, of the other files, those pyproject's package-data globs match (globbed in the
    # package's folder, as setuptools globs them): a file of src/vilma no glob matches is in no install
    package = ROOT / "src/vilma"
    data = {p.relative_to(package).as_posix() for p in package.rglob("*") if p.is_file() and p.suffix != ".py"
            and p.suffix not in CACHES and "__pycache__" not in p.parts}
    matched = {m for g in PYPROJECT["tool"]["setuptools"]["package-data"]["vilma"]
               for m in glob.glob(g, root_dir=package)}
    assert {"py.typed", "scenarios/course_30kmh_stanley.yaml", "scenarios/data/README.md"} <= data
    assert data - matched == set()
    assert not [m for m in matched if "__pycache__" in m or os.path.splitext(m)[1] in CACHES]


def _manifest() -> dict[str, set[str]]:
    """MANIFEST.in's commands and their patterns (setuptools' list of the sdist's files beside the package)."""
    commands: dict[str, set[str]] = {}
    for line in (ROOT / "MANIFEST.in").read_text().splitlines():
        if line.strip() and not line.lstrip().startswith("#"):
            command, *patterns = line.split()
            commands.setdefault(command, set()).update(patterns)
    return commands


def test_the_sdist_holds_what_the_tests_read_and_no_caches():
    # the sdist is a source release its tests run from: setuptools puts src/ (the packages), the readme, the licence
    # files, pyproject and MANIFEST.in in it, MANIFEST.in the rest
    manifest = _manifest()
    shipped = {"src", "README.md", "LICENSE", "pyproject.toml", "MANIFEST.in"} | manifest["graft"] | manifest["include"]
    read = {m.partition("/")[0] for f in (ROOT / "tests").rglob("*.py")
            for m in re.findall(r'ROOT / "([\w./-]+)"', f.read_text())}
    assert read and read | {"tests"} <= shipped
    assert {f"*{c}" for c in CACHES} <= {e for p in manifest["global-exclude"] for e in _expand(p)}
    assert "**/__pycache__" in manifest["prune"]


def _expand(pattern: str) -> set[str]:
    """A glob's character classes spelt out: ``*.py[co]`` -> ``*.pyc``, ``*.pyo``."""
    m = re.fullmatch(r"(.*)\[(\w+)\](.*)", pattern)
    return {m[1] + c + m[3] for c in m[2]} if m else {pattern}


ROS1 = {"rospy", "genpy", "geometry_msgs", "sensor_msgs", "std_msgs"}
"""Debian's ROS 1 (``vilma ros1-bridge``): not on PyPI, so in no extra; the command says what to install."""
NOT_FOR_USERS = {"test", "docs", "benchmark"}
"""Extras for vilma's own tests, site and benchmarks: vilma's code may import nothing only they bring."""


def _declared() -> set[str]:
    """The distributions a user's install of vilma can have: its dependencies and its user extras' (an extra of a
    dependency counts as the distribution it names, as ``dask[distributed]``: distributed)."""
    extras = PYPROJECT["project"]["optional-dependencies"]
    reqs = [Requirement(r) for r in PYPROJECT["project"]["dependencies"]]
    reqs += [Requirement(r) for name, rs in extras.items() if name not in NOT_FOR_USERS for r in rs]
    return {canonicalize_name(n) for r in reqs for n in (r.name, *r.extras)} - {"vilma"}


def _imported_packages(path: Path) -> set[str]:
    """The top-level names of the absolute imports in ``path``'s module."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name.partition(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.partition(".")[0])
    return names


def test_every_package_vilma_imports_is_declared():
    # an import of a package that only arrives with another (a dependency's dependency) or with the test extra
    # works in the checkout's venv and fails in a user's install
    dists = importlib.metadata.packages_distributions()  # import name -> the installed distributions holding it
    declared = _declared()
    undeclared = {}
    for path in sorted((ROOT / "src/vilma").rglob("*.py")):
        for name in _imported_packages(path) - set(sys.stdlib_module_names) - ROS1 - {"vilma"}:
            if not {canonicalize_name(d) for d in dists.get(name, [name])} & declared:
                undeclared.setdefault(name, path.relative_to(ROOT).as_posix())
    assert undeclared == {}


def _complete(line: str, tmp_path: Path) -> list[str]:
    """What the shell would offer after ``line``: argcomplete's protocol, as its bash hook runs it."""
    out = tmp_path / "completions"
    env = {**os.environ, "_ARGCOMPLETE": "1", "_ARGCOMPLETE_IFS": "\n", "COMP_LINE": line,
           "COMP_POINT": str(len(line)), "_ARGCOMPLETE_STDOUT_FILENAME": str(out)}
    r = subprocess.run([sys.executable, "-m", "vilma"], env=env, cwd=tmp_path, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    return [c.strip() for c in out.read_text().split("\n")]  # a lone completion ends with a space


def test_completion_offers_commands_options_and_bundled_scenarios(tmp_path):
    (tmp_path / "course_mine.yaml").write_text("task: {speed: 1}\n")
    assert {"scenarios", "run", "sim"} <= set(_complete("vilma ", tmp_path))
    assert {"--verbose", "--quiet"} <= set(_complete("vilma run --", tmp_path))
    bundled = {p.stem for p in (ROOT / "src/vilma/scenarios").glob("course_30*.yaml")}
    assert len(bundled) >= 4 and set(_complete("vilma run course_30", tmp_path)) == bundled
    assert set(_complete("vilma sim course_m", tmp_path)) == {"course_mine.yaml"}  # files too


@pytest.mark.parametrize("path", ["src/vilma/app/cli.py", "src/vilma/__main__.py"])
def test_marked_for_global_completion(path):
    # activate-global-python-argcomplete completes a script whose first 1024 bytes hold the marker
    assert "# PYTHON_ARGCOMPLETE_OK" in (ROOT / path).read_text()[:1024]


@pytest.mark.slow
def test_the_wheel_ships_the_licences_and_py_typed(tmp_path):
    # built from a copy: setuptools builds in the source tree (build/, src/vilma.egg-info), and a module deleted
    # later stayed in build/lib and in every wheel built from that checkout after
    source = tmp_path / "source"
    shutil.copytree(ROOT, source, symlinks=True, ignore=shutil.ignore_patterns(
        ".*", "build", "dist", "runs", "*.egg-info", "__pycache__", *(f"*{c}" for c in CACHES)))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp_path), str(source)],
                   check=True, capture_output=True, timeout=600)
    (wheel,) = tmp_path.glob("vilma-*.whl")
    files = set(zipfile.ZipFile(wheel).namelist())
    info = f"vilma-{vilma.__version__}.dist-info"
    assert {"vilma/py.typed", "vilma/__main__.py", "vilma/scenarios/data/README.md", f"{info}/licenses/LICENSE",
            f"{info}/licenses/src/vilma/scenarios/data/README.md",
            f"{info}/licenses/src/vilma/scenarios/data/commonroad/LICENSE-commonroad-io.txt"} <= files
    data = ROOT / "src/vilma/scenarios"
    shipped = {f"vilma/scenarios/{p.relative_to(data).as_posix()}" for p in data.rglob("*")
               if p.is_file() and "__pycache__" not in p.parts}
    assert shipped <= files  # the scenarios, the logs, the CommonRoad files and their notices together
