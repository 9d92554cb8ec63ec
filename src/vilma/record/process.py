"""A :class:`~vilma.record.recorder.Recorder` in a process of its own, as ``rosbag record`` is: the loop hands
over its arrays and goes on, while the text encoding and the compression run on another core.

The calls travel over a pipe (numpy arrays pickled without a copy of their own); the child is forked, so it
starts at once with everything imported and compiled. A recording error is printed by the child and ends
the recording only (:attr:`RecorderProcess.ok` turns false); :meth:`RecorderProcess.close` waits for the
file to be finished.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import queue
import signal
import threading
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

from vilma.record.recorder import Recorder

OUTBOX = 64
"""Calls queued for the pipe at most (the caller waits beyond: memory stays bounded)."""
CALLS = ("add_readings", "add_log_rows", "add_message", "add_attachment", "add_metadata")
"""The recorder's methods that go to the child."""


def _serve(conn: Connection, parent_end: Connection, path: Path, options: dict[str, Any]) -> None:
    """The child: make the recorder, then do the calls as they come until ``close`` (or until the parent is
    gone: the file is finished either way). Ctrl-C is the parent's to handle; a failing call ends the
    recording, keeping what was written."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent_end.close()  # forked with it: only the parent may hold that end, or the pipe would never end
    recorder = Recorder(path, **options)
    error = None
    while True:
        try:
            name, args = conn.recv()
        except EOFError:
            name, args = "close", ()
        if name == "close":
            recorder.close()
            with contextlib.suppress(OSError):
                conn.send(error or recorder.error)
            return
        if error is not None:
            continue
        try:
            getattr(recorder, name)(*args)
        except Exception as e:  # a bug must not lose what is written
            recorder.on_error(f"recording stopped by {name}: {e}; what was written is kept")
            recorder.close()
            error = f"{name}: {e}"
        error = error or recorder.error
        if error is not None:
            conn.send(error)


class RecorderProcess:
    """A :class:`~vilma.record.recorder.Recorder` of ``path`` (``options``: its keyword arguments) in a child
    process; same calls (:data:`CALLS`), and :meth:`close`."""

    def __init__(self, path: Path, **options: Any) -> None:
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe()
        self._process = ctx.Process(target=_serve, args=(child, self._conn, Path(path), options), daemon=True,
                                    name="vilma-recorder")
        self._process.start()
        child.close()
        self.error: str | None = None
        self._outbox: queue.Queue = queue.Queue(maxsize=OUTBOX)
        self._sender = threading.Thread(target=self._send, name="vilma-recorder-pipe", daemon=True)
        self._sender.start()

    def _send(self) -> None:
        """Write the calls into the pipe (blocking while the child is busy), so the caller never waits."""
        while True:
            call = self._outbox.get()
            try:
                self._conn.send(call)
            except (OSError, ValueError):
                return
            if call[0] == "close":
                return

    @property
    def ok(self) -> bool:
        """Whether the recording is still going (false once the child reported an error, or after close)."""
        if self.error is None and self._conn is not None and self._conn.poll():
            self.error = self._conn.recv()
        return self.error is None and self._conn is not None

    def __getattr__(self, name: str):
        if name not in CALLS:
            raise AttributeError(name)

        def call(*args: Any) -> None:
            if self.ok:
                self._outbox.put((name, args))
        return call

    def close(self) -> None:
        """Finish the file and wait for the child (the file is complete when this returns)."""
        if self._conn is None:
            return
        replies = []
        self._outbox.put(("close", ()))
        self._sender.join()
        try:
            while True:  # an error it reported earlier, then its answer to close, then the end of the pipe
                replies.append(self._conn.recv())
        except (EOFError, BrokenPipeError):
            pass
        if not replies:
            replies.append("the recording process ended early; the file may be incomplete")
        self.error = self.error or next((r for r in replies if r), None)
        self._conn.close()
        self._conn = None
        self._process.join()
