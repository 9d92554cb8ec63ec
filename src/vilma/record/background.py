"""A :class:`~vilma.record.recorder.Recorder` fed by a thread of its own: the loop hands over its arrays and goes
on, while the packing and the compression (which release the GIL) run on another core.

Calls queue up in order (at most :data:`OUTBOX`: beyond, the caller waits, so memory stays bounded); the thread
closes a chunk that is a second old even while nothing comes. A call that fails ends the recording only,
keeping what was written (:attr:`BackgroundRecorder.error` says why); :meth:`BackgroundRecorder.close` returns
once the file is finished. If the process is killed, the file is readable up to its last flushed chunk.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from vilma.record.recorder import Recorder

OUTBOX = 64
"""Calls queued at most."""
_CLOSE = object()


class BackgroundRecorder:
    """A :class:`~vilma.record.recorder.Recorder` of ``path`` (``options``: its keyword arguments) in a thread."""

    def __init__(self, path: Path, **options: Any) -> None:
        self.recorder = Recorder(path, **options)
        self.error: str | None = self.recorder.error
        self._queue: queue.Queue = queue.Queue(maxsize=OUTBOX)
        self._thread = threading.Thread(target=self._serve, name="vilma-recorder", daemon=True)
        self._thread.start()

    def _serve(self) -> None:
        rec = self.recorder
        while True:
            try:
                call = self._queue.get(timeout=rec.policy.chunk_seconds / 2)
            except queue.Empty:
                rec.tick()
                continue
            if call is _CLOSE:
                rec.close()
                return
            if self.error is not None:
                continue
            fn, args = call
            try:
                fn(rec, *args)
            except Exception as e:  # a bug must not lose what is written
                rec.on_error(f"recording stopped by {fn.__name__}: {e}; what was written is kept")
                rec.close()
                self.error = f"{fn.__name__}: {e}"
            self.error = self.error or rec.error

    @property
    def ok(self) -> bool:
        """Whether the recording is still going (false once a call failed, or after close)."""
        return self.error is None and self._thread.is_alive()

    def call(self, fn: Callable[..., None], *args: Any) -> None:
        """Do ``fn(recorder, *args)`` in the thread, after the calls before it (nothing once the recording
        stopped). The arguments must not change afterwards: they are not copied."""
        if self.ok:
            self._queue.put((fn, args))

    def close(self) -> None:
        """Finish the file and wait for the thread (the file is complete when this returns)."""
        if self._thread.is_alive():
            self._queue.put(_CLOSE)
            self._thread.join()
        self.error = self.error or self.recorder.error
