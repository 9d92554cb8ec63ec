"""Atomic writes: whole or not at all, with the mode the umask gives, errors naming the file."""

from __future__ import annotations

import os
import stat

import pytest

from vilma.core.files import atomic_path, write_atomic


@pytest.fixture
def umask_027():
    old = os.umask(0o027)
    yield
    os.umask(old)


def test_new_and_replaced_files_get_the_umask_mode(tmp_path, umask_027):
    f = tmp_path / "metrics.json"
    write_atomic(f, "{}\n")
    assert stat.S_IMODE(f.stat().st_mode) == 0o666 & ~0o027
    f.chmod(0o644)  # an earlier output, as another umask made it: replaced by a file of this one
    write_atomic(f, b"[]\n")
    assert f.read_bytes() == b"[]\n" and stat.S_IMODE(f.stat().st_mode) == 0o640
    assert os.listdir(tmp_path) == ["metrics.json"]


def test_a_failed_write_keeps_the_earlier_file_and_names_it(tmp_path, full_disk):
    f = tmp_path / "scenario.yaml"
    f.write_text("old\n")
    with pytest.raises(OSError, match="No space left on device") as e:
        write_atomic(f, "new\n")
    assert e.value.filename == str(f) and str(f) in str(e.value)
    assert f.read_text() == "old\n" and os.listdir(tmp_path) == ["scenario.yaml"]


def test_an_error_inside_the_block_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "p.png") as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("plot failed")
    assert os.listdir(tmp_path) == []
