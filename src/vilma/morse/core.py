"""The MORSE services and the robot's state, without any I/O.

:class:`MorseCore` answers request lines (``simulation``, ``time``, the robot's
original services, component services), turns actuator datastream lines and
service calls into :class:`~vilma.core.messages.ActuatorCommand` and sensor
readings and laser scans into MORSE dicts. :class:`~vilma.morse.server.MorseServer` runs it on
sockets; everything here runs on the server's one event-loop thread, but what the simulator's thread
reports (frame times, resets applied), which is behind locks.
"""

from __future__ import annotations

import json
import logging
import math
import threading
import time
from collections.abc import Callable, Collection, Container, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from vilma.core.messages import ActuatorCommand, Message
from vilma.morse import protocol as p
from vilma.morse.access import CommandAccess
from vilma.morse.components import (
    LASER_RANGE,
    CommandValueError,
    ComponentSpec,
    OriginalCar,
    SensorMapper,
    components,
    finite,
    laser_dict,
    motion_command,
    motion_target,
    mounts,
    steer_force_command,
)
from vilma.morse.frames import FrameTimes
from vilma.morse.scene import configurations, details, scene_objects
from vilma.sensors import SensorSuite
from vilma.sensors.base import Readings
from vilma.vehicle.params import VehicleParams, vilma

log = logging.getLogger(__name__)

MAX_PENDING = 256
"""Most ``reset_objects`` requests waiting at once for the simulator to reset."""
SLEEP_BUSY = "A service (sleep) is already running. I do not know what to do."
"""MORSE's reply to a ``time sleep`` while one runs (its ``time`` component runs one asynchronous service)."""
RESET_DONE = "Objects restored to initial position"
"""MORSE's reply to ``reset_objects``."""

UNSUPPORTED = (
    "suspend_dynamics", "restore_dynamics", "set_log_level", "set_object_position",
    "set_object_visibility", "set_object_dynamics", "set_camarafp_far_clip", "set_camarafp_position",
    "set_camarafp_transform", "set_camarafp_projection_matrix", "get_camarafp_projection_matrix",
)
"""MORSE ``simulation`` services about its 3D scene, physics engine and camera, which vilma answers FAILED."""


class Peer(Protocol):
    """A service connection as the core sees it: the peer's IP ``address`` and a way to send reply bytes."""

    address: str

    def send(self, data: bytes) -> None:
        """Queue ``data`` to the peer (never blocks)."""


@dataclass(frozen=True, slots=True)
class _Service:
    fn: Callable[..., Any]
    params: tuple[str, ...] = ()
    command: bool = False
    """Moves the car or the simulation: refused from peers outside ``allow_commands_from``."""
    is_async: bool = False


@dataclass(slots=True)
class _Pending:
    """A request answered later: ``time sleep`` once the sim time reaches ``due`` [ns], ``reset_objects`` once
    readings come after ``due`` resets applied in all."""

    peer: Peer
    id: str
    due: int


_ASYNC = object()


class MorseCore:
    """State and services of one robot on a MORSE socket interface.

    Args:
        robot: robot name (``[A-Za-z0-9_]+``); components are ``<robot>.pose`` ...
        on_command: called with every actuator command (must be cheap).
        on_reset: called by ``simulation reset_objects`` (None: the service fails).
        on_quit: called after ``simulation quit`` is answered (None: the service fails).
        time_ns: current sim time [ns].
        allow_commands_from: peers (addresses or networks) whose commands are taken; None: everyone.
        vehicle: the car (wheelbase, limits for MotionVW); default the ``vilma`` preset.
        shutdown: called after ``quit`` has been answered, before ``on_quit`` (the server closes its sockets).
        world_topics: the simulator's world sensor topics; ``laser`` adds the ``laser`` component.
        laser_range: the laser's reach [m], reported for a ray without a hit (as MORSE).
        sensors: the car's sensors (where the GPS and IMU are mounted); default :class:`SensorSuite`'s.
        wall_ns: a monotonic wall clock [ns] (``time statistics``).

    ``on_reset`` gets a function to call (on any thread) once the simulator has put the car back, before its
    next readings come: ``reset_objects`` answers then, so that what is read after its reply is the reset state.
    """

    def __init__(self, *, robot: str = "vilma", on_command: Callable[[ActuatorCommand], None],
                 on_reset: Callable[[Callable[[], None]], None] | None = None,
                 on_quit: Callable[[], None] | None = None, time_ns: Callable[[], int],
                 allow_commands_from: Collection[str] | None = None, vehicle: VehicleParams | None = None,
                 shutdown: Callable[[], None] | None = None, world_topics: Collection[str] = (),
                 laser_range: float = LASER_RANGE, sensors: SensorSuite | None = None,
                 wall_ns: Callable[[], int] = time.monotonic_ns) -> None:
        if not robot or not robot.replace("_", "").isalnum() or not robot.isascii():
            raise ValueError(f"robot name {robot!r} must be letters, digits and '_' (it prefixes 'robot.pose')")
        self.robot = robot
        self._on_command, self._on_reset, self._on_quit = on_command, on_reset, on_quit
        self._time_ns = time_ns
        self.access = CommandAccess(allow_commands_from)
        self.vehicle = vehicle or vilma()
        self._shutdown = shutdown
        if not 0 < laser_range < math.inf:
            raise ValueError(f"laser_range must be a positive number of metres, got {laser_range!r}")
        self.laser_range = laser_range
        self.specs: dict[str, ComponentSpec] = {f"{robot}.{c.name}": c for c in components(world_topics)}
        self.mounts = mounts(sensors or SensorSuite())
        self.by_reading = {c.reading: fqn for fqn, c in self.specs.items() if c.reading}
        self.stream_ports: dict[str, int] = {}
        self.active = dict.fromkeys(self.specs, True)
        self.latest: dict[str, dict[str, Any]] = {}
        self.dropped: dict[str, int] = {}
        """Malformed world-sensor messages dropped, by component."""
        self.car = OriginalCar()
        self.mapper = SensorMapper()
        self._motion: tuple[float, float] | None = None
        self._speed = 0.0
        self._sleeping: _Pending | None = None
        self._last_now: int | None = None
        self._resetting: list[_Pending] = []
        self._resets_lock = threading.Lock()
        self._resets_applied = 0  # counted on the simulator's thread
        self._resets_seen = 0
        self.frames = FrameTimes(time_ns, wall_ns)
        self._quitting = False
        self._services = self._registry()

    # -- service requests ----------------------------------------------------------------------------------

    def handle_line(self, peer: Peer, raw: bytes | p.TooLong) -> None:
        """Answer one request line (bytes without ``\\n``); replies go to ``peer.send``. Never raises."""
        try:
            self._handle(peer, raw)
        except Exception as e:  # a bug must not take the server down: answer it and keep serving
            log.exception("MORSE request %r failed", raw)
            rid = p.first_token(raw.head if isinstance(raw, p.TooLong) else raw)
            peer.send(p.format_reply(rid, p.FAILED, f"vilma internal error: {type(e).__name__}: {e}"))
        if self._quitting:
            self._quitting = False
            if self._shutdown is not None:
                self._shutdown()
            if self._on_quit is not None:
                try:
                    self._on_quit()
                except Exception:
                    log.exception("on_quit failed")

    def _handle(self, peer: Peer, raw: bytes | p.TooLong) -> None:
        if isinstance(raw, p.TooLong):
            peer.send(p.format_reply(p.first_token(raw.head), p.FAILED,
                                     f"Request longer than {p.MAX_LINE} bytes: send one request per line, "
                                     f"each ending in a newline"))
            return
        req = p.parse_request(raw.decode("utf-8", "replace"))
        if req is None:
            return
        if isinstance(req, p.Invalid):
            peer.send(p.format_reply(req.id, p.FAILED, req.message))
            return
        if isinstance(req, p.Cancel):
            self._cancel(peer, req.id)
            return
        status, result = self._call(peer, req)
        if status is not None:
            peer.send(p.format_reply(req.id, status, result))

    def _call(self, peer: Peer, req: p.Request) -> tuple[str | None, Any]:
        svc = self._services.get((req.component, req.service))
        if svc is None:
            if req.component == "simulation" and req.service in UNSUPPORTED:
                return p.FAILED, (f"simulation {req.service} is not supported by vilma's MORSE interface: "
                                  f"vilma has no 3D scene, physics engine or camera to change")
            return p.FAILED, p.not_registered(req.service)
        if svc.command and not self.access.allowed(peer.address):
            return p.FAILED, self.access.refusal(peer.address)
        if len(req.params) != len(svc.params):
            if not req.params:
                return p.FAILED, p.missing_params(req.service, svc.params)
            return p.FAILED, p.wrong_count(req.service, svc.params, len(req.params))
        try:
            result = svc.fn(peer, req.id, *req.params) if svc.is_async else svc.fn(*req.params)
        except CommandValueError as e:
            return p.FAILED, p.wrong_type(req.service, str(e))
        except p.RequestError as e:
            return p.FAILED, str(e)
        if result is _ASYNC:
            return None, None
        return p.SUCCESS, result

    def _registry(self) -> dict[tuple[str, str], _Service]:
        r = self.robot
        reg = {
            ("simulation", "list_robots"): _Service(lambda: [r]),
            ("simulation", "details"): _Service(lambda: details(r, self.specs, self.stream_ports)),
            ("simulation", "list_streams"): _Service(lambda: list(self.stream_ports)),
            ("simulation", "get_stream_port"): _Service(self._get_stream_port, ("component",)),
            ("simulation", "get_all_stream_ports"): _Service(lambda: dict(self.stream_ports)),
            ("simulation", "reset_objects"): _Service(self._reset, command=True, is_async=True),
            ("simulation", "quit"): _Service(self._quit, command=True),
            ("simulation", "terminate"): _Service(self._quit, command=True),
            ("simulation", "activate"): _Service(lambda c: self._activate(c, True), ("component",), command=True),
            ("simulation", "deactivate"): _Service(lambda c: self._activate(c, False), ("component",),
                                                   command=True),
            ("simulation", "get_scene_objects"): _Service(
                lambda: scene_objects(r, self.specs, self.mounts, self._local_data(f"{r}.pose"))),
            ("time", "now"): _Service(lambda: self._now() / 1e9),
            ("time", "sleep"): _Service(self._sleep, ("time",), is_async=True),
            ("time", "mode"): _Service(lambda: "Fixed Simulation Step"),
            ("time", "statistics"): _Service(self.frames.statistics),
            (r, "steer"): _Service(self._car_call(self.car.steer), ("Steering", "steeringAmount"), command=True),
            (r, "controlpower"): _Service(self._car_call(self.car.controlpower),
                                          ("controlPower", "powerAmount", "velocityAmount"), command=True),
            (r, "power"): _Service(self._car_call(self.car.power), ("Power", "powerAmount", "velocityAmount"),
                                   command=True),
            (r, "brake"): _Service(self._car_call(self.car.brake), ("Brake", "brakeAmount"), command=True),
            (r, "autonomous"): _Service(self._car_call(self.car.set_autonomous), ("autonomous",), command=True),
            (r, "status"): _Service(self._status),
            (f"{r}.motion", "set_speed"): _Service(self._set_speed, ("v", "w"), command=True),
            (f"{r}.motion", "stop"): _Service(lambda: self._set_speed(0.0, 0.0), command=True),
        }
        for fqn, spec in self.specs.items():
            calls = {"get_local_data": lambda fqn=fqn: self._local_data(fqn),
                     "get_properties": lambda spec=spec: {"properties": dict(spec.properties)},
                     "get_configurations": lambda spec=spec: configurations(spec, self.mounts)}
            reg.update({(fqn, name): _Service(call) for name, call in calls.items() if name in spec.services})
        return reg

    # -- simulation and time services -----------------------------------------------------------------------

    def _get_stream_port(self, component: Any) -> int:
        port = self.stream_ports.get(component) if isinstance(component, str) else None
        if port is None:
            raise p.RequestError(f"Stream unavailable for component {component}")
        return port

    def _activate(self, component: Any, on: bool) -> None:
        if not isinstance(component, str) or component not in self.active:
            verb = "activate" if on else "deactivate"
            raise p.RequestError(f"Component {component!r} not found. Can't {verb}")
        self.active[component] = on

    def _reset(self, peer: Peer, rid: str) -> object:
        if self._on_reset is None:
            raise p.RequestError("simulation reset_objects is not available: this vilma simulator was started "
                                 "without a reset handler; reset it from its own controls")
        if len(self._resetting) >= MAX_PENDING:
            raise p.RequestError(f"{MAX_PENDING} reset_objects requests already wait for the simulator to reset; "
                                 f"wait for their replies")
        self._resetting.append(_Pending(peer, rid, self.resets_applied + 1))  # counted before the reset can apply
        try:
            self._on_reset(self._reset_applied)
        except Exception as e:
            self._resetting.pop()
            log.exception("on_reset failed")
            raise p.RequestError(f"vilma could not reset the simulation: {e}") from e
        self.car = OriginalCar()
        self._motion = None
        return _ASYNC

    def _reset_applied(self) -> None:
        with self._resets_lock:
            self._resets_applied += 1

    @property
    def resets_applied(self) -> int:
        """The resets of ``reset_objects`` the simulator has applied so far (read it from any thread)."""
        with self._resets_lock:
            return self._resets_applied

    def catch_up(self, resets_applied: int) -> None:
        """What comes next was published after ``resets_applied`` (:attr:`resets_applied` then): after a new
        reset, forget what was measured before it and answer the ``reset_objects`` it served."""
        if resets_applied <= self._resets_seen:
            return
        self._resets_seen = resets_applied
        self.latest.clear()
        self.mapper.reset()
        done = [q for q in self._resetting if q.due <= resets_applied]
        self._resetting = [q for q in self._resetting if q.due > resets_applied]
        for q in done:
            q.peer.send(p.format_reply(q.id, p.SUCCESS, RESET_DONE))

    def _quit(self) -> None:
        if self._on_quit is None:
            raise p.RequestError("simulation quit is not available: this vilma simulator was started without a "
                                 "quit handler; stop it from its own console")
        self._quitting = True

    def _now(self) -> int:
        return int(self._time_ns())

    def _sleep(self, peer: Peer, rid: str, seconds: Any) -> object:
        if self._sleeping is not None:
            raise p.RequestError(SLEEP_BUSY)
        s = finite("time", seconds)
        self._sleeping = _Pending(peer, rid, self._now() + round(min(s, 1e12) * 1e9))  # 1e12 s: never
        self.check_pending()
        return _ASYNC

    def _cancel(self, peer: Peer, rid: str) -> None:
        """Preempt the running ``time sleep`` if it is ``rid`` of ``peer``; anything else is ignored (as MORSE)."""
        q = self._sleeping
        if q is not None and q.peer is peer and q.id == rid:
            self._sleeping = None
            peer.send(p.format_reply(rid, p.PREEMPTED))

    def check_pending(self) -> None:
        """Answer the running ``time sleep`` once its sim time has come (sim time going back shifts it)."""
        q = self._sleeping
        if q is None:
            self._last_now = None
            return
        now = self._now()
        if self._last_now is not None and now < self._last_now:  # the simulation was reset
            q.due += now - self._last_now
        self._last_now = now
        if q.due <= now:
            self._sleeping = None
            q.peer.send(p.format_reply(q.id, p.SUCCESS))

    def waiting(self, peer: Peer) -> bool:
        """Whether a request of ``peer`` is still to be answered (``time sleep``, ``reset_objects``)."""
        return (self._sleeping is not None and self._sleeping.peer is peer) or any(
            q.peer is peer for q in self._resetting)

    def peer_gone(self, peer: Peer) -> None:
        """Forget the requests of a closed connection (its ``time sleep`` no longer blocks others')."""
        if self._sleeping is not None and self._sleeping.peer is peer:
            self._sleeping = None
        self._resetting = [q for q in self._resetting if q.peer is not peer]

    # -- robot and component services ------------------------------------------------------------------------

    def _car_call(self, method: Callable[..., None]) -> Callable[..., None]:
        name = method.__name__

        def call(*args: Any) -> None:
            getattr(self.car, name)(*args)
            self._motion = None
            self._emit(self.car.command(self._now()), raise_errors=True)

        return call

    def _status(self) -> float:
        v = self.latest.get(f"{self.robot}.velocity")
        return math.hypot(*v["linear_velocity"][:2]) if v else 0.0

    def _local_data(self, fqn: str) -> dict[str, Any]:
        data = self.latest.get(fqn)
        if data is None:
            raise p.RequestError(f"no {fqn} reading yet: the simulator has not published one; try again once "
                                 f"it runs")
        return data

    def _set_speed(self, v: Any, w: Any) -> None:
        target = (finite("v", v), finite("w", w))
        self._motion = target
        self._drive_motion(raise_errors=True)

    def _drive_motion(self, raise_errors: bool = False) -> None:
        if self._motion is not None and self.active[f"{self.robot}.motion"]:
            v, w = self._motion
            self._emit(motion_command(v, w, self._speed, self.vehicle, self._now()), raise_errors)

    def _emit(self, cmd: ActuatorCommand, raise_errors: bool = False) -> None:
        try:
            self._on_command(cmd)
        except Exception as e:
            log.exception("on_command failed for %r", cmd)
            if raise_errors:
                raise p.RequestError(f"the simulator refused the command: {e}") from e

    # -- datastreams ------------------------------------------------------------------------------------------

    def actuator_line(self, fqn: str, address: str, line: bytes) -> str | None:
        """Apply one line received on actuator stream ``fqn`` from ``address``; the error text, or None."""
        if not self.access.allowed(address):
            return self.access.refusal(address)
        if not self.active.get(fqn, False):
            return None  # a deactivated actuator ignores its stream, as in MORSE
        try:
            msg = json.loads(line)
        except (ValueError, RecursionError) as e:
            return f"{fqn}: not a JSON object ({e}); send one JSON object per line"
        spec = self.specs[fqn]
        try:
            if spec.type == "SteerForce":
                cmd = steer_force_command(msg, self._now())
                self._motion = None
                self._emit(cmd)
            else:
                self._motion = motion_target(msg)
                self._drive_motion()
        except CommandValueError as e:
            return f"{fqn}: {e}"
        return None

    def readings(self, readings: dict[str, Readings], wanted: Container[str]) -> dict[str, bytes]:
        """Take one batch of sensor readings: MORSE JSON lines by component, for the components in ``wanted``
        (the others only update their latest data). Also drives MotionVW and answers due ``time sleep``."""
        out: dict[str, bytes] = {}
        for name, r in readings.items():
            fqn = self.by_reading.get(name)
            if fqn is None or not len(r) or not self.active[fqn]:
                continue
            streamed = fqn in wanted
            if not streamed:
                r = Readings(r.name, r.message, r.stamp_ns[-1:], r.values[-1:])
            dicts = self.mapper.dicts(r)
            if not dicts:
                continue
            self.latest[fqn] = dicts[-1]
            if streamed:
                out[fqn] = "".join(json.dumps(d) + "\n" for d in dicts).encode()
        vel = self.latest.get(f"{self.robot}.velocity")
        if vel is not None:
            self._speed = vel["linear_velocity"][0]
        self._drive_motion()
        self.check_pending()
        return out

    def captures(self, captures: Mapping[str, Message] | Iterable[tuple[str, Message]],
                 wanted: Container[str]) -> dict[str, bytes]:
        """Take world-sensor messages (topic name -> message, or (topic, message) pairs in time order, as
        ``Simulator.take_captures`` gives them; ``laser`` -> a scan): MORSE JSON lines by component, for the
        components in ``wanted`` (the others only update their latest data). A malformed message is dropped (a
        one-line warning, the first of each component)."""
        lines: dict[str, list[str]] = {}
        for name, msg in (captures.items() if isinstance(captures, Mapping) else captures):
            fqn = self.by_reading.get(name)
            if fqn is None or self.specs[fqn].type != "LaserScanner" or not self.active[fqn]:
                continue
            try:
                data = laser_dict(msg, self.laser_range)
            except ValueError as e:
                n = self.dropped[fqn] = self.dropped.get(fqn, 0) + 1
                log.log(logging.WARNING if n == 1 else logging.DEBUG, "MORSE %s: %s; scan dropped", fqn, e)
                continue
            self.latest[fqn] = data
            if fqn in wanted:
                lines.setdefault(fqn, []).append(json.dumps(data) + "\n")
        return {fqn: "".join(parts).encode() for fqn, parts in lines.items()}
