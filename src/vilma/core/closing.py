"""Resources that open something (a socket, a session, a file, a renderer) close at the end of a ``with``."""

from __future__ import annotations

import abc
import contextlib


class Closeable(contextlib.AbstractContextManager):
    """A resource with :meth:`close`: ``with X(...) as x:`` gives ``x`` and closes it however the block ends
    (an exception from the block still propagates)."""

    @abc.abstractmethod
    def close(self) -> None:
        """Release what the resource holds; a second call does nothing."""

    def __exit__(self, *exc: object) -> None:
        self.close()
