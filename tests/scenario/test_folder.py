"""Each run its own folder; an earlier run is never overwritten unless asked, and then not mixed with the new."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from vilma.app.batch import Job, out_dirs
from vilma.scenario import load_scenario
from vilma.scenario.fields import SpecError
from vilma.scenario.folder import NAME_BYTES, RUN_FILES, claim, folder_name


def _job(tmp_path: Path, folder: str, sets: tuple = (), name: str | None = None) -> Job:
    f = tmp_path / folder / "s.yaml"
    f.parent.mkdir(parents=True, exist_ok=True)
    f.write_text(("" if name is None else f"name: {json.dumps(name)}\n") + "task: {speed: 5}\nduration: 2\n")
    return Job(load_scenario(f, dict(sets)), sets)


def test_every_run_of_a_batch_gets_its_own_folder(tmp_path):
    a, b = _job(tmp_path, "a"), _job(tmp_path, "b")
    same = _job(tmp_path, "a", (("seed", "1"),))
    dirs = out_dirs([a, b, same, same, _job(tmp_path, "a", (("task.speed", "5"),))], tmp_path / "out")
    assert [d.name for d in dirs] == ["a-s", "b-s", "s-seed_1", "s-seed_1-2", "s-task.speed_5"]
    assert out_dirs([a], tmp_path / "one") == [tmp_path / "one"]
    default = out_dirs([a, b], None)
    assert len(set(default)) == 2 and all(d.parent == Path("runs") for d in default)


@pytest.mark.parametrize(("name", "folder"), [
    ("step-task.speed_4", "step-task.speed_4"), ("../../../escape", "escape"), ("/tmp/x/victim", "tmp_x_victim"),
    ("", "run"), ("..", "run"), ("a\nb", "a_b"), (".hidden", "hidden"), ("-rf", "rf"), ("a\\b\x00c\u202ed", "a_b_c_d"),
    ("Überholen 2", "Überholen_2"),
])
def test_a_name_is_one_folder_name(name, folder):
    assert folder_name(name) == folder


def test_a_long_name_is_cut_to_whole_characters():
    for name in ("x" * 300, "é" * 300):
        f = folder_name(name)
        assert len(f.encode()) <= NAME_BYTES and name.startswith(f) and len(f.encode()) > NAME_BYTES - 2


def test_no_scenario_name_or_file_puts_a_run_outside_its_root(tmp_path, monkeypatch):
    names = ("../../../escape", str(tmp_path / "victim"), "", "a\nb", "x" * 300, "../../../escape")
    hostile = [_job(tmp_path, "w/n", name=n) for n in names]
    for folder in ("w", "w/d", "."):
        _job(tmp_path, folder)
    monkeypatch.chdir(tmp_path / "w")
    same = [Job(load_scenario(f)) for f in ("s.yaml", "d/s.yaml", "../s.yaml")]
    dirs = out_dirs([*hostile, *same], tmp_path / "out")
    assert all(d.parent == tmp_path / "out" and not d.name.startswith((".", "-")) for d in dirs)
    assert len(set(dirs)) == len(dirs)
    assert [d.name for d in dirs[-3:]] == ["w-s", "d-s", f"{tmp_path.name}-s"]  # the files' folders, not "" or ".."
    assert all(d.parent == Path("runs") for d in out_dirs(hostile, None))


def test_a_folder_that_holds_anything_is_refused(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    (d / "notes.txt").write_text("mine")
    with pytest.raises(SpecError, match=r"run: holds an earlier run or other files \(notes.txt\); give --overwrite"):
        claim([d], overwrite=False)
    claim([tmp_path / "new", tmp_path / "empty"], overwrite=False)  # missing or empty: fine
    (tmp_path / "file").write_text("")
    with pytest.raises(SpecError, match="file: it is a file, not a folder; choose another --out"):
        claim([tmp_path / "file"], overwrite=True)
    with pytest.raises(SpecError, match=f"file/sub/run: {tmp_path / 'file'} is a file, not a folder; choose another"):
        claim([tmp_path / "file" / "sub" / "run"], overwrite=True)


def test_a_folder_that_cannot_be_written_is_refused_before_anything(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    if os.access(ro, os.W_OK):  # root writes in any folder; not on a read-only file system
        ro = Path("/proc/sys")
    if os.access(ro, os.W_OK):
        pytest.skip("no folder this user cannot write in")
    with pytest.raises(SpecError, match=f"{ro}: cannot write in it .*; choose another --out"):
        claim([ro], overwrite=True)
    with pytest.raises(SpecError, match=f"{ro / 'a' / 'b'}: cannot write in {ro} "):
        claim([ro / "a" / "b"], overwrite=False)


def test_overwrite_clears_the_earlier_run_and_keeps_the_rest(tmp_path):
    d = tmp_path / "run"
    (d / "run-report").mkdir(parents=True)
    for name in (*RUN_FILES, "notes.txt"):
        (d / name).write_text("old")
    claim([d], overwrite=True)
    assert [p.name for p in d.iterdir()] == ["notes.txt"]
