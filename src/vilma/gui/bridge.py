"""Between the bus and the GUI thread: latest messages, plot history, recording, sending, connection state.

Bus callbacks run on the bus's threads (the simulator's thread on the local
bus, Zenoh's threads otherwise). They only store: the latest message of each
topic, a row in a ring buffer, a line in a recording. Then, at most once per
topic until the GUI thread has taken it, they emit :attr:`BusBridge.updated`,
which Qt queues to the GUI thread. Everything the GUI sends (commands,
orders, requests with replies) goes through one worker thread, in order, so
the GUI thread never waits on the bus.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import logging
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path

from PySide6.QtCore import QObject, QTimer, Signal, Slot

from vilma.bus.base import Bus
from vilma.bus.topics import topic
from vilma.core.messages import (
    ActuatorCommand,
    ActuatorState,
    DriverOrder,
    DriverStatus,
    Message,
    Pose,
    Reply,
    SimControl,
    Velocity,
)
from vilma.gui.history import RingBuffer, capacity_for
from vilma.trajectory import SpeedRecorder, TrajectoryRecorder

log = logging.getLogger(__name__)

WATCHED = ("pose", "velocity", "gps", "imu", "wheel_speed", "actuators", "cmd", "sim/status", "driver/status",
           "perception/objects", "planning/plan")
"""Topics the GUI subscribes to."""

HISTORY_COLUMNS = {
    "path": ("t", "x", "y"),
    "speed": ("t", "speed"),
    "actuators": ("t", "steer", "drive_force", "brake_force"),
    "driver": ("t", "target_speed", "speed", "cross_track", "index"),
}
"""Plot histories and their columns: time [s], position [m], speed [m/s], steer [rad], forces [N],
cross-track error [m], active segment."""


class BusBridge(QObject):
    """The GUI's side of the bus (see the module docstring).

    Args:
        bus: the bus to watch and send on.
        car: the car's name in topic keys.
        history_seconds: plot history kept [s] at ``history_rate`` [Hz] (the fastest sensor's rate).
        stale_after: without a simulator status for this long [s] the link is shown as lost.
        world_topics: the 3D plant's camera and laser topics to watch too (their latest message only).
    """

    updated = Signal(str)
    """A topic has news (its short name, e.g. ``pose``); ``reset`` when sim time went back."""
    connection_changed = Signal(bool)
    """The simulator is heard (True) or has been silent for ``stale_after`` (False)."""
    replied = Signal(str, object)
    """The answer to an order: what was ordered, and the :class:`Reply`."""

    def __init__(self, bus: Bus, car: str = "vilma", history_seconds: float = 3600.0, history_rate: float = 100.0,
                 stale_after: float = 1.0, world_topics: tuple[str, ...] = (), parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.bus, self.car, self.stale_after = bus, car, stale_after
        self.latest: dict[str, Message] = {}
        cap = capacity_for(history_rate, history_seconds)
        self.history = {name: RingBuffer(cap, len(cols)) for name, cols in HISTORY_COLUMNS.items()}
        self.connected = False
        self.last_heard = -math.inf
        """Wall time of the last simulator status [s, time.monotonic]."""
        self._pending: set[str] = set()
        self._pending_lock = threading.Lock()
        self._rec_lock = threading.Lock()
        self._recorders: dict[str, TrajectoryRecorder | SpeedRecorder] = {}
        self._last_stamp = -1
        self._worker = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="vilma-gui-send")
        self._closed = False
        self._subs = [bus.subscribe(topic(name, car), self._handler(name)) for name in (*WATCHED, *world_topics)]
        self._timer = QTimer(self)
        self._timer.timeout.connect(self.check_connection)
        self._timer.start(100)

    # -- from the bus (any thread) -------------------------------------------------------------------

    def _handler(self, name: str) -> Callable[[Message], None]:
        def take(msg: Message) -> None:
            self.latest[name] = msg
            if name == "sim/status":
                self.last_heard = time.monotonic()
            self._store(name, msg)
            self._notify(name)
        return take

    def _store(self, name: str, msg: Message) -> None:
        t = msg.stamp_ns * 1e-9
        if isinstance(msg, Pose):
            if msg.stamp_ns < self._last_stamp:  # the simulation was reset: a new run
                for h in self.history.values():
                    h.clear()
                self._notify("reset")
            self._last_stamp = msg.stamp_ns
            self.history["path"].append((t, msg.x, msg.y))
            with self._rec_lock:
                rec = self._recorders.get("trajectory")
                if rec is not None:
                    rec.add(msg.stamp_ns, msg.x, msg.y)
        elif isinstance(msg, Velocity):
            self.history["speed"].append((t, msg.speed))
            with self._rec_lock:
                rec = self._recorders.get("speed")
                if rec is not None:
                    rec.add(msg.stamp_ns, msg.speed)
        elif isinstance(msg, ActuatorState):
            self.history["actuators"].append((t, msg.steer, msg.drive_force, msg.brake_force))
        elif isinstance(msg, DriverStatus) and msg.mode != "manual":
            self.history["driver"].append((t, msg.target_speed, msg.speed, msg.cross_track, msg.index))

    def _notify(self, name: str) -> None:
        with self._pending_lock:
            if name in self._pending or self._closed:
                return
            self._pending.add(name)
        self._emit_updated(name)

    def _emit_updated(self, name: str) -> None:
        with contextlib.suppress(RuntimeError):  # the bridge was deleted while a bus thread was delivering
            self.updated.emit(name)

    # -- in the GUI thread ------------------------------------------------------------------------------

    def taken(self, name: str) -> None:
        """The GUI has handled the news of ``name``: the next message may signal again."""
        with self._pending_lock:
            self._pending.discard(name)

    @Slot()
    def check_connection(self) -> None:
        """Compare the time since the simulator was last heard with ``stale_after``; signal a change."""
        now = time.monotonic() - self.last_heard < self.stale_after
        if now != self.connected:
            self.connected = now
            self.connection_changed.emit(now)

    def clear_history(self) -> None:
        """Forget the plot history."""
        for h in self.history.values():
            h.clear()

    # -- sending (one worker thread, in order) -------------------------------------------------------------

    def command(self, cmd: ActuatorCommand) -> concurrent.futures.Future:
        """Publish an actuator command on ``cmd``."""
        return self._submit(self.bus.publish, topic("cmd", self.car), cmd)

    def order(self, order: DriverOrder, what: str | None = None) -> concurrent.futures.Future:
        """Send an order to the driver; :attr:`replied` carries its answer."""
        return self._ask(topic("driver/cmd", self.car), order, what or order.action)

    def sim_control(self, action: str) -> concurrent.futures.Future:
        """Send an order to the simulator (``reset``, ``status``); :attr:`replied` carries its answer."""
        return self._ask(topic("sim/cmd", self.car), SimControl(action=action), f"simulator {action}")

    def call(self, fn: Callable[[], object], what: str) -> concurrent.futures.Future:
        """Run ``fn()`` on the worker; its error (if any) comes back as a failed :attr:`replied`."""
        def run() -> None:
            try:
                fn()
            except Exception as e:  # shown to the user, never raised into Qt
                log.exception("%s failed", what)
                self._reply(what, Reply(ok=False, error=str(e)))
            else:
                self._reply(what, Reply(ok=True))
        return self._submit(run)

    def _ask(self, key: str, msg: Message, what: str) -> concurrent.futures.Future:
        def run() -> None:
            self._reply(what, self.bus.request(key, msg))
        return self._submit(run)

    def _reply(self, what: str, reply: Reply) -> None:
        if not self._closed:
            with contextlib.suppress(RuntimeError):
                self.replied.emit(what, reply)

    def _submit(self, fn, *args) -> concurrent.futures.Future:
        if self._closed:
            f: concurrent.futures.Future = concurrent.futures.Future()
            f.set_result(None)
            return f
        return self._worker.submit(fn, *args)

    # -- recording -----------------------------------------------------------------------------------------

    def start_recording(self, kind: str, path: str | Path, period: float = 0.25) -> Path:
        """Start writing ``trajectory`` (PositionLog) or ``speed`` (SpeedLog) to ``path``, every ``period`` [s].

        Raises:
            OSError: the file cannot be created.
        """
        rec = TrajectoryRecorder(path, period) if kind == "trajectory" else SpeedRecorder(path, period)
        with self._rec_lock:
            old = self._recorders.pop(kind, None)
            self._recorders[kind] = rec
        if old is not None:
            old.close()
        return rec.path

    def stop_recording(self, kind: str) -> Path | None:
        """Stop a recording and close its file; returns its path (None if it was not recording)."""
        with self._rec_lock:
            rec = self._recorders.pop(kind, None)
        if rec is None:
            return None
        rec.close()
        return rec.path

    def recording(self, kind: str) -> bool:
        """Whether ``kind`` is being recorded."""
        return kind in self._recorders

    def close(self, wait: bool = True) -> None:
        """Unsubscribe, finish the sends queued, close recordings."""
        with self._pending_lock:
            self._closed = True
        self._timer.stop()
        for s in self._subs:
            s.close()
        self._worker.shutdown(wait=wait, cancel_futures=not wait)
        for kind in list(self._recorders):
            self.stop_recording(kind)
