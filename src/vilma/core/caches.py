"""Where numba keeps vilma's compiled code: a folder this user can write, in any install.

numba keeps a module's compiled functions beside it (``__pycache__``) or, where that folder is read-only (a system
or container image's install, a venv shared read-only), in its user-wide folder (``$XDG_CACHE_HOME/numba``, by
default ``~/.cache/numba``). Where neither can be written (a service's user without a home, a read-only home) its
``cache=True`` raises at import, and every vilma command would stop with a traceback. Then, and only then, vilma
names a private folder of this user in the temporary directory as ``$NUMBA_CACHE_DIR`` (:func:`ensure_numba_cache`,
run when vilma is imported): vilma compiles once per boot rather than never starting. ``$NUMBA_CACHE_DIR`` set by
the user is left alone."""

from __future__ import annotations

import os
import stat
import sys

NUMBA_CACHE_ENV = "NUMBA_CACHE_DIR"
"""numba's variable for the folder of its caches (read when numba is imported, and again on its reload)."""

PRIVATE_PREFIX = "vilma-numba"
"""The temporary folder's name: ``<prefix>-<uid>`` in the temporary directory."""


def can_write(folder: str) -> bool:
    """Whether this process could write in ``folder``, making it and its missing parents first [bool]: the nearest
    existing one is a folder it may write in (``os.access``: permissions, a read-only mount), without writing (quick
    enough for every import of vilma)."""
    while not os.path.lexists(folder):
        parent = os.path.dirname(folder)
        if parent == folder:
            return False
        folder = parent
    return os.path.isdir(folder) and os.access(folder, os.W_OK | os.X_OK)


def writes(folder: str) -> bool:
    """Whether this process can make ``folder`` and write a file in it [bool], tried as numba's locator tries it (the
    folder is left made): :func:`can_write` cannot tell for the superuser, whom only a read-only mount stops."""
    import tempfile

    try:
        os.makedirs(folder, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def numba_user_folder() -> str:
    """numba's user-wide cache folder [path], as its locator computes it (platform aware)."""
    from numba.misc.appdirs import AppDirs

    return AppDirs(appname="numba", appauthor=False).user_cache_dir


def private_folder(prefix: str = PRIVATE_PREFIX, temp: str | None = None) -> str:
    """A folder of this user's alone in the temporary directory ``temp`` (default :func:`tempfile.gettempdir`)
    [path]: ``<prefix>-<uid>``, made with mode 0700 and kept across runs, or a new one of its own when that path is
    anything else (another user's, a link, open to others): numba loads its cache files with pickle.

    Raises:
        OSError: no folder can be made there.
    """
    import tempfile

    temp = temp or tempfile.gettempdir()
    path = os.path.join(temp, f"{prefix}-{os.getuid()}")
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    except OSError:
        return tempfile.mkdtemp(prefix=f"{prefix}-", dir=temp)
    st = os.lstat(path)
    if stat.S_ISDIR(st.st_mode) and st.st_uid == os.getuid() and not st.st_mode & 0o077:
        return path
    return tempfile.mkdtemp(prefix=f"{prefix}-", dir=temp)


def ensure_numba_cache(package: str, temp: str | None = None) -> str | None:
    """Name a folder numba can write vilma's compiled code in where it would find none [path, or None when numba's
    own choice stands]: ``$NUMBA_CACHE_DIR`` is set, or the ``package`` folder's ``__pycache__`` or numba's user-wide
    folder can be written. Else ``$NUMBA_CACHE_DIR`` becomes :func:`private_folder` (in ``temp``), for this process
    and those it starts, and an imported numba reloads its configuration. Nothing is set when no folder can be made
    there either: numba then says what it could not do."""
    if os.environ.get(NUMBA_CACHE_ENV) or can_write(os.path.join(package, "__pycache__")):
        return None
    if writes(numba_user_folder()):
        return None
    try:
        folder = private_folder(temp=temp)
    except OSError:
        return None
    os.environ[NUMBA_CACHE_ENV] = folder
    config = sys.modules.get("numba.core.config")
    if config is not None:  # numba read the variable when it was imported (numba_user_folder imported it)
        config.reload_config()
    return folder


def numba_cache_of(package: str) -> str:
    """Where numba keeps ``package``'s compiled code now [words]: for a message on what to delete."""
    chosen = os.environ.get(NUMBA_CACHE_ENV)
    if chosen and can_write(chosen):
        return f"{chosen} ($NUMBA_CACHE_DIR)"
    if can_write(os.path.join(package, "__pycache__")):
        return f"the __pycache__ folders under {package}"
    return numba_user_folder()
