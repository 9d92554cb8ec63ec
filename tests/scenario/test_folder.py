"""Each run its own folder; an earlier run is never overwritten unless asked, and then not mixed with the new."""

from __future__ import annotations

from pathlib import Path

import pytest

from vilma.app.batch import Job, out_dirs
from vilma.scenario import load_scenario
from vilma.scenario.fields import SpecError
from vilma.scenario.folder import RUN_FILES, claim


def _job(tmp_path: Path, folder: str, sets: tuple = ()) -> Job:
    f = tmp_path / folder / "s.yaml"
    f.parent.mkdir(exist_ok=True)
    f.write_text("task: {speed: 5}\nduration: 2\n")
    return Job(load_scenario(f, dict(sets)), sets)


def test_every_run_of_a_batch_gets_its_own_folder(tmp_path):
    a, b = _job(tmp_path, "a"), _job(tmp_path, "b")
    same = _job(tmp_path, "a", (("seed", "1"),))
    dirs = out_dirs([a, b, same, same, _job(tmp_path, "a", (("task.speed", "5"),))], tmp_path / "out")
    assert [d.name for d in dirs] == ["a-s", "b-s", "s-seed_1", "s-seed_1-2", "s-task.speed_5"]
    assert out_dirs([a], tmp_path / "one") == [tmp_path / "one"]
    default = out_dirs([a, b], None)
    assert len(set(default)) == 2 and all(d.parent == Path("runs") for d in default)


def test_a_folder_that_holds_anything_is_refused(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    (d / "notes.txt").write_text("mine")
    with pytest.raises(SpecError, match=r"run: holds an earlier run or other files \(notes.txt\); give --overwrite"):
        claim([d], overwrite=False)
    claim([tmp_path / "new", tmp_path / "empty"], overwrite=False)  # missing or empty: fine
    (tmp_path / "file").write_text("")
    with pytest.raises(SpecError, match="is a file, not a folder"):
        claim([tmp_path / "file"], overwrite=True)


def test_overwrite_clears_the_earlier_run_and_keeps_the_rest(tmp_path):
    d = tmp_path / "run"
    (d / "run-report").mkdir(parents=True)
    for name in (*RUN_FILES, "notes.txt"):
        (d / name).write_text("old")
    claim([d], overwrite=True)
    assert [p.name for p in d.iterdir()] == ["notes.txt"]
