"""Where numba keeps vilma's compiled code when the install or the home cannot be written."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys

from vilma.core.caches import NUMBA_CACHE_ENV, can_write, ensure_numba_cache, numba_cache_of, private_folder, writes


def _unmakeable(tmp_path):
    """A folder no one can make, not even the superuser: its parent is a regular file."""
    (tmp_path / "file").write_text("")
    return str(tmp_path / "file" / "folder")


def test_a_folder_can_be_written_where_its_nearest_existing_parent_can(tmp_path):
    assert can_write(str(tmp_path)) and can_write(str(tmp_path / "a" / "b"))
    assert not can_write(_unmakeable(tmp_path)) and not writes(_unmakeable(tmp_path))
    assert writes(str(tmp_path / "c")) and (tmp_path / "c").is_dir()


def test_a_writable_install_or_the_users_choice_leaves_numba_alone(tmp_path, monkeypatch):
    monkeypatch.delenv(NUMBA_CACHE_ENV, raising=False)
    assert ensure_numba_cache(str(tmp_path), temp=str(tmp_path)) is None  # numba caches beside the modules
    assert NUMBA_CACHE_ENV not in os.environ
    monkeypatch.setenv(NUMBA_CACHE_ENV, str(tmp_path / "mine"))
    assert ensure_numba_cache(_unmakeable(tmp_path), temp=str(tmp_path)) is None
    assert os.environ[NUMBA_CACHE_ENV] == str(tmp_path / "mine")
    assert numba_cache_of(_unmakeable(tmp_path)) == f"{tmp_path / 'mine'} ($NUMBA_CACHE_DIR)"


def test_a_read_only_install_and_home_give_numba_a_private_folder(tmp_path):
    # numba raised at import then (no locator for the cache); in a child: numba's configuration is reloaded
    script = ("import json, sys, numba\n"
              "from numba.core import config\n"
              "from vilma.core.caches import ensure_numba_cache\n"
              "folder = ensure_numba_cache(sys.argv[1], temp=sys.argv[2])\n"
              "print(json.dumps([folder, config.CACHE_DIR]))\n")
    home = _unmakeable(tmp_path)
    env = {**os.environ, "HOME": home, "XDG_CACHE_HOME": os.path.join(home, ".cache")}
    env.pop(NUMBA_CACHE_ENV, None)
    r = subprocess.run([sys.executable, "-c", script, _unmakeable(tmp_path), str(tmp_path)], env=env,
                       capture_output=True, text=True, timeout=120, check=True)
    folder, numba_reads = json.loads(r.stdout)
    assert folder == numba_reads == str(tmp_path / f"vilma-numba-{os.getuid()}")
    st = os.stat(folder)
    assert st.st_uid == os.getuid() and stat.S_IMODE(st.st_mode) == 0o700


def test_a_private_folder_open_to_others_or_a_link_is_not_used(tmp_path):
    path = tmp_path / f"vilma-numba-{os.getuid()}"
    path.mkdir()
    path.chmod(0o777)  # another user could have put pickles there
    other = private_folder(temp=str(tmp_path))
    assert other != str(path) and stat.S_IMODE(os.stat(other).st_mode) == 0o700
    path.rmdir()
    path.symlink_to(tmp_path / "elsewhere")
    assert private_folder(temp=str(tmp_path)) not in (str(path), other)
    path.unlink()
    assert private_folder(temp=str(tmp_path)) == str(path)  # made now: this user's alone, kept for the next run
