"""Files written whole or not at all: a temporary file beside the target, then a rename.

A failed write leaves the earlier file as it was. New files get the mode the
user's umask gives (the temporary file is created as ``open`` would create
the target, not with ``mkstemp``'s 0600). Errors are ``OSError`` naming the
file and saying that the earlier one is untouched.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; renamed over ``path`` when the block ends without error,
    removed otherwise."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as e:
        raise write_error(path, e) from None
    finally:
        tmp.unlink(missing_ok=True)


def write_atomic(path: Path, data: str | bytes) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` whole or not at all; returns ``path``."""
    with atomic_path(path) as tmp:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "wb") as f:
            f.write(data.encode() if isinstance(data, str) else data)
            f.flush()
            os.fsync(f.fileno())
    return Path(path)


def write_error(path: Path, e: OSError) -> OSError:
    """``e`` as an error naming ``path`` (a full disk says which file it could not write)."""
    return OSError(e.errno, f"{e.strerror or e}; the earlier file, if any, is untouched", str(path))
