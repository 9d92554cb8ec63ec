"""A :class:`~vilma.record.recorder.Recorder` in a process of its own, as ``rosbag record`` is: the loop hands
over its arrays and goes on, and shares no interpreter lock with the packing and the compression.

The child is a fresh interpreter, not a fork (a forked copy of a large process makes the parent copy every
page it writes afterwards). Each call is pickled into a ring of shared memory with its numpy arrays beside
the pickle, not in it (a :class:`Joined` list of arrays is joined there: one copy, no concatenation), and a
pipe carries where it lies; the child reads the arrays in place, does the call, then frees its part of the
ring. The parent waits only when the ring is full. The child is in a session of its
own (Ctrl-C is the parent's to handle), closes a chunk that is a second old while nothing comes, and
finishes the file when the parent closes it or vanishes. A call that fails ends the recording only, keeping
what was written (:attr:`RecorderProcess.error` says why).
"""

from __future__ import annotations

import contextlib
import fcntl
import io
import math
import mmap
import os
import pickle
import select
import subprocess
import sys
import time
from collections.abc import Callable
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

import numpy as np

RING = 8 << 20
"""Bytes of shared memory for the calls on their way, by default [bytes] (small: each page costs the parent a
fault the first time it writes there)."""
_SLACK = 1 << 16
"""Bytes of a call's room kept for its pickle stream and alignment [bytes]."""
_HEADER = 64
"""Bytes before the ring: the child's progress (int64: bytes of the ring done with, counted from the start)."""
_PIPE = 1 << 20
"""Size asked for the pipe of call notices [bytes]."""


_GONE = "the recording process ended early; the file may be incomplete"


def _aligned(n: int) -> int:
    return (n + 63) & ~63


class Joined:
    """Arrays of one dtype and row shape that a call's function gets as one, ``np.concatenate(parts)``: they are
    joined in the ring, where the call's arrays are copied anyway."""

    __slots__ = ("dtype", "nbytes", "parts", "shape")

    def __init__(self, parts: list[np.ndarray]) -> None:
        self.parts = parts
        self.dtype = parts[0].dtype
        self.shape = (sum(len(a) for a in parts), *parts[0].shape[1:])
        self.nbytes = self.dtype.itemsize * math.prod(self.shape)


class _Pickler(pickle.Pickler):
    """Pickles a call; its arrays (C-ordered, of a plain dtype; others go in the pickle) and :class:`Joined` lists
    go to ``arrays``, each named in the pickle by its dtype and shape."""

    def __init__(self, file: io.BytesIO, arrays: list[Joined]) -> None:
        super().__init__(file, protocol=pickle.HIGHEST_PROTOCOL)
        self.arrays = arrays

    def persistent_id(self, obj: Any) -> tuple[str, tuple[int, ...]] | None:
        if (type(obj) is np.ndarray and obj.ndim and obj.flags.c_contiguous and not obj.dtype.hasobject
                and obj.dtype.fields is None):  # its dtype.str names it whole
            obj = Joined([obj])
        elif type(obj) is not Joined:
            return None
        self.arrays.append(obj)
        return obj.dtype.str, obj.shape


class _Unpickler(pickle.Unpickler):
    """Unpickles a call whose arrays lie in ``arrays`` (buffers, in the order :class:`_Pickler` met them)."""

    def __init__(self, stream: bytes, arrays: list) -> None:
        super().__init__(io.BytesIO(stream))
        self.arrays = iter(arrays)

    def persistent_load(self, pid: tuple[str, tuple[int, ...]]) -> np.ndarray:
        dtype, shape = pid
        return np.frombuffer(next(self.arrays), dtype, math.prod(shape)).reshape(shape)


class RecorderProcess:
    """A :class:`~vilma.record.recorder.Recorder` of ``path`` (``options``: its keyword arguments, picklable) in a
    child process, with a ring of ``ring`` bytes (a multiple of 64)."""

    def __init__(self, path: Path, ring: int = RING, **options: Any) -> None:
        mem_fd = os.memfd_create("vilma-recorder")
        os.ftruncate(mem_fd, _HEADER + ring)
        self._mem = mmap.mmap(mem_fd, _HEADER + ring)
        self._done = np.frombuffer(self._mem, np.int64, 1)
        self._ring = np.frombuffer(self._mem, np.uint8, ring, _HEADER)
        calls_r, calls_w = os.pipe()
        replies_r, replies_w = os.pipe()
        with contextlib.suppress(OSError):
            fcntl.fcntl(calls_w, fcntl.F_SETPIPE_SZ, _PIPE)
        src = str(Path(__file__).resolve().parents[2])  # vilma's own, whatever the child's path
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [src, os.environ.get("PYTHONPATH")]))}
        self._child = subprocess.Popen(
            [sys.executable, "-m", "vilma.record.process", str(mem_fd), str(calls_r), str(replies_w)],
            pass_fds=(mem_fd, calls_r, replies_w), stdin=subprocess.DEVNULL, start_new_session=True, env=env)
        for fd in (mem_fd, calls_r, replies_w):
            os.close(fd)
        self._calls = Connection(calls_w, readable=False)
        self._replies = Connection(replies_r, writable=False)
        self._replied = select.poll()  # a microsecond a look (Connection.poll takes a hundred)
        self._replied.register(replies_r, select.POLLIN)
        self._head = 0
        self.error: str | None = None
        self._calls.send((Path(path), options))

    @property
    def ok(self) -> bool:
        """Whether the recording is still going (false once the child reported an error, or after finish)."""
        if self.error is None and not self._calls.closed:
            self.error = self._trouble()
        return self.error is None and not self._calls.closed

    def _trouble(self) -> str | None:
        """The error the child reported, or that it is gone (its end of the replies closed); None while it is
        well."""
        try:
            while self._replied.poll(0):
                reply = self._replies.recv()
                if reply:
                    return reply
        except (OSError, EOFError):
            return _GONE
        return None

    def call(self, fn: Callable[..., None], *args: Any) -> None:
        """Do ``fn(recorder, *args)`` in the child, after the calls before it (nothing once the recording stopped).
        ``fn`` must be importable by name (a module's function, or a method of the recorder); a :class:`Joined`
        in ``args`` reaches it as one array."""
        if not self.ok:
            return
        arrays: list[Joined] = []
        file = io.BytesIO()
        _Pickler(file, arrays).dump((fn, args))
        stream = file.getbuffer()
        sizes = [stream.nbytes, *(a.nbytes for a in arrays)]
        total = sum(_aligned(n) for n in sizes)
        if total > len(self._ring) // 2:  # too big for the ring: through the pipe
            self._send(("pipe", bytes(stream), [np.concatenate(a.parts).tobytes() for a in arrays]))
            return
        start = self._reserve(total)
        if start is None:
            return
        at = start % len(self._ring)
        self._ring[at:at + stream.nbytes] = np.frombuffer(stream, np.uint8)
        at += _aligned(stream.nbytes)
        for a in arrays:
            np.concatenate(a.parts, out=self._ring[at:at + a.nbytes].view(a.dtype).reshape(a.shape))
            at += _aligned(a.nbytes)
        self._send(("ring", start % len(self._ring), sizes, start + total))

    @property
    def capacity(self) -> int:
        """Bytes a call's arrays may take through the ring (a bigger call goes through the pipe)."""
        return len(self._ring) // 2 - _SLACK

    def room(self) -> int:
        """Bytes a call's arrays may take now without waiting for the child (it may still be starting)."""
        ring = len(self._ring)
        free, tail = ring - (self._head - int(self._done[0])), ring - self._head % ring  # tail: to the ring's end
        return min(self.capacity, max(min(free, tail), free - tail) - _SLACK)  # a call never straddles the end

    def _reserve(self, size: int) -> int | None:
        """Where ``size`` bytes of the ring go (counted from the start), once free; None if the child is gone."""
        start, ring = self._head, len(self._ring)
        if start % ring + size > ring:  # it would straddle the end: from the ring's start
            start += ring - start % ring
        while start + size - int(self._done[0]) > ring:
            if not self.ok:
                return None
            time.sleep(0.001)
        self._head = start + size
        return start

    def _send(self, message: tuple) -> None:
        try:
            self._calls.send(message)
        except OSError:
            self.error = self.error or self._trouble() or _GONE

    def finish(self) -> None:
        """Have the child finish the file, without waiting for it (:meth:`close` waits); no calls after this."""
        if self._calls.closed:
            return
        with contextlib.suppress(OSError):
            self._calls.send(("close",))
        self._calls.close()

    def close(self) -> None:
        """Finish the file and wait for the child (the file is complete when this returns)."""
        if self._child is None:
            return
        self.finish()
        replies = []
        with contextlib.suppress(EOFError, OSError):
            while True:  # an error it reported earlier, then its answer to close, then the end of the pipe
                replies.append(self._replies.recv())
        self._replies.close()
        self._child.wait()
        if not replies:
            replies.append(_GONE)
        self.error = self.error or next((r for r in replies if r), None)
        self._child = None
        del self._done, self._ring
        self._mem.close()


class RecorderHere:
    """A :class:`~vilma.record.recorder.Recorder` of ``path`` in this process, with :class:`RecorderProcess`'s
    calls: for a drive that runs unpaced, where a second interpreter's start (half a second, its imports) costs
    more than the packing it would take off the loop."""

    capacity = 1 << 62
    """Bytes a call may take (no ring here)."""

    def __init__(self, path: Path, **options: Any) -> None:
        from vilma.record.recorder import Recorder

        self._recorder = Recorder(path, **options)
        self.error: str | None = self._recorder.error
        self._open = True

    @property
    def ok(self) -> bool:
        """Whether the recording is still going."""
        self.error = self.error or self._recorder.error
        return self.error is None and self._open

    def call(self, fn: Callable[..., None], *args: Any) -> None:
        """Do ``fn(recorder, *args)`` now (a :class:`Joined` reaches it as one array); nothing once stopped."""
        if not self.ok:
            return
        try:
            args = _join(args)
            fn(self._recorder, *args)
        except Exception as e:  # a bug must not lose what is written
            self._recorder.on_error(f"recording stopped by {fn.__name__}: {e}; what was written is kept")
            self.error = f"{fn.__name__}: {e}"
            self.finish()

    def room(self) -> int:
        """Bytes a call may take now."""
        return self.capacity

    def finish(self) -> None:
        """Finish the file."""
        if self._open:
            self._open = False
            self._recorder.close()
            self.error = self.error or self._recorder.error

    close = finish


def _join(obj: Any) -> Any:
    """``obj`` with each :class:`Joined` in it (in tuples, lists and dicts) as its one array."""
    if isinstance(obj, Joined):
        return np.concatenate(obj.parts)
    if isinstance(obj, tuple | list):
        return type(obj)(_join(o) for o in obj)
    if isinstance(obj, dict):
        return {k: _join(v) for k, v in obj.items()}
    return obj


def _serve(mem_fd: int, calls_fd: int, replies_fd: int) -> None:
    """The child: make the recorder, then do the calls as they come until ``close`` or the end of the pipe."""
    from vilma.record.recorder import Recorder

    mem = mmap.mmap(mem_fd, 0)
    done = np.frombuffer(mem, np.int64, 1)
    ring = memoryview(mem)[_HEADER:]
    calls, replies = Connection(calls_fd, writable=False), Connection(replies_fd, readable=False)
    path, options = calls.recv()
    recorder = Recorder(path, **options)
    error = recorder.error
    if error is not None:
        replies.send(error)
    while True:
        if not calls.poll(recorder.policy.chunk_seconds / 2):
            recorder.tick()
            continue
        try:
            message = calls.recv()
        except EOFError:  # the parent is gone
            message = ("close",)
        if message[0] == "close":
            recorder.close()
            with contextlib.suppress(OSError):
                replies.send(error or recorder.error)
            replies.close()
            os._exit(0)  # the file is finished: spare the interpreter's teardown (half a second with numba)
        if message[0] == "ring":
            _, at, sizes, end = message
            views = []
            for n in sizes:
                views.append(ring[at:at + n])
                at += _aligned(n)
            fn, args = _Unpickler(views[0], views[1:]).load()
        else:  # through the pipe
            (fn, args), end = _Unpickler(message[1], message[2]).load(), None
        if error is None:
            try:
                fn(recorder, *args)
            except Exception as e:  # a bug must not lose what is written
                recorder.on_error(f"recording stopped by {fn.__name__}: {e}; what was written is kept")
                recorder.close()
                error = f"{fn.__name__}: {e}"
            error = error or recorder.error
            if error is not None:
                replies.send(error)
        del fn, args
        if end is not None:
            done[0] = end


if __name__ == "__main__":
    _serve(*(int(a) for a in sys.argv[1:]))
