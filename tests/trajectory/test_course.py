import os
import stat
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from vilma.trajectory import course as course_module
from vilma.trajectory.course import PAPER_COURSE, cache_dir, course, spline_course


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("VILMA_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache" / "courses"


def _no_spline(*_):
    raise AssertionError("the spline was made again")


def test_a_course_is_made_once_then_read_from_the_cache_bit_for_bit(cache, monkeypatch):
    made = spline_course(PAPER_COURSE)
    first = course(PAPER_COURSE)
    assert np.array_equal(first.xy, made.xy) and len(list(cache.glob("*.npy"))) == 1
    monkeypatch.setattr(course_module, "spline_course", _no_spline)
    again = course(PAPER_COURSE)
    assert again.xy.tobytes() == made.xy.tobytes()
    with pytest.raises(AssertionError, match="made again"):  # another course, or spacing, is another file
        course(PAPER_COURSE, 0.25)


@pytest.mark.parametrize("content", [b"", b"not an array", None])
def test_a_damaged_cache_file_is_made_again(cache, content):
    course(PAPER_COURSE)
    (file,) = cache.glob("*.npy")
    if content is None:
        np.save(file, np.zeros((3, 3)))  # an array of the wrong shape
    else:
        file.write_bytes(content)
    assert np.array_equal(course(PAPER_COURSE).xy, spline_course(PAPER_COURSE).xy)
    assert np.array_equal(np.load(file), spline_course(PAPER_COURSE).xy)


def test_an_unwritable_cache_folder_still_gives_the_course(tmp_path, monkeypatch):
    blocker = tmp_path / "a file"
    blocker.write_text("")
    monkeypatch.setenv("VILMA_CACHE_DIR", str(blocker))  # its "courses" folder cannot be made
    assert np.array_equal(course(PAPER_COURSE).xy, spline_course(PAPER_COURSE).xy)


def test_the_cache_folder_follows_xdg_when_not_set(monkeypatch, tmp_path):
    monkeypatch.delenv("VILMA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_dir() == tmp_path / "vilma"


def _no_home() -> Path:
    raise RuntimeError("Could not determine home directory.")  # (what Path.home raises then)


def test_a_user_whose_cache_home_cannot_be_written_keeps_courses_in_a_private_temporary_folder(monkeypatch, tmp_path):
    (tmp_path / "file").write_text("")
    monkeypatch.delenv("VILMA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "file" / "cache"))  # (under a file: no one can make it)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    folder = tmp_path / f"vilma-cache-{os.getuid()}"
    assert cache_dir() == folder and stat.S_IMODE(folder.stat().st_mode) == 0o700
    assert np.array_equal(course(PAPER_COURSE).xy, spline_course(PAPER_COURSE).xy)
    assert len(list((folder / "courses").glob("*.npy"))) == 1  # kept for the next run
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setattr(Path, "home", _no_home)
    assert cache_dir() == folder  # a user id without a home (none in the password database)


def test_a_course_scenario_loaded_again_in_a_new_process_does_not_import_the_spline_library(cache):
    code = ("import sys; from vilma.scenario import load_scenario; "
            "load_scenario('course_30kmh_stanley').reference_path(); print('scipy.interpolate' in sys.modules)")
    first = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    second = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert (first.stdout.split(), second.stdout.split()) == (["True"], ["False"])
