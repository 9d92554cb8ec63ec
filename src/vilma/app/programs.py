"""The long-running programs: ``vilma sim``, ``vilma drive`` and ``vilma up``.

Each runs until its duration is over or SIGINT / SIGTERM arrives, then closes
its bus and servers (within a second).
"""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

from vilma.bus.base import Bus
from vilma.bus.local import LocalBus
from vilma.bus.nodes import DriverNode, SimNode
from vilma.bus.paced import run_paced
from vilma.control.driver import Driver
from vilma.morse import MorseServer
from vilma.morse.access import parse_networks
from vilma.morse.components import LASER_RANGE
from vilma.morse.ports import ListenError
from vilma.record.live import FoxgloveLive
from vilma.record.recorder import BusRecorder, Recorder
from vilma.record.road_scene import scenario_road
from vilma.scenario.orders import plan_setup, task_order
from vilma.scenario.runner import initial_state, sim_config
from vilma.scenario.spec import Scenario, to_yaml
from vilma.sim import SimConfig, Simulator

log = logging.getLogger(__name__)

@dataclass(frozen=True)
class MorseOptions:
    """Where ``vilma sim`` serves the MORSE socket interface (``vilma.morse``): the first service port tried
    (the next free up to +9; 0: any), the first datastream port (0: any), and the peers whose commands are
    taken (None: all)."""

    host: str = "127.0.0.1"
    service_port: int = 4000
    stream_port: int = 60000
    allow_commands_from: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        for name in ("service_port", "stream_port"):
            if not 0 <= getattr(self, name) <= 65535:
                raise ValueError(f"MORSE {name.replace('_', ' ')} must be in 0..65535 (0: any free port), "
                                 f"got {getattr(self, name)}")
        parse_networks(self.allow_commands_from)  # a bad address fails before anything starts


MORSE_OPTIONS = {"host": "--morse-host", "service_port": "--morse-port", "stream_port": "--morse-stream-port"}
"""``vilma sim``'s option of each :class:`MorseServer` argument."""


@contextlib.contextmanager
def stop_on_signals() -> Iterator[threading.Event]:
    """An event set by SIGINT, SIGTERM or SIGHUP (a closed terminal; unless ignored, as ``nohup`` does) while the block
    runs. The previous handlers come back after it, unless one of those signals came: the program is then shutting
    down, and a repeat must not kill it half way (``timeout`` sends its TERM twice, to the program and to its process
    group), so they keep only setting the event."""
    stop = threading.Event()
    signalled = threading.Event()

    def handler(*_) -> None:
        signalled.set()
        stop.set()

    old = {s: signal.signal(s, handler) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
           if signal.getsignal(s) != signal.SIG_IGN}
    try:
        yield stop
    finally:
        if not signalled.is_set():
            for s, h in old.items():
                signal.signal(s, h)


def serve_driver(driver: Driver, bus: Bus, car: str, step_ns: int, scenario: Scenario | None,
                 data_dir: Path | None = None) -> DriverNode:
    """The driver node on ``bus`` (following orders may name the trajectory files in ``data_dir``); with a
    scenario, its task starts once the driver knows where the car is, as an order (published as a peer's are:
    recordings hold it), a plan task with the scenario's planner and perception."""
    node = DriverNode(driver, bus, car, step_ns, data_dir, plan_setup(scenario))
    if scenario is not None:
        order = task_order(scenario)

        def start() -> None:
            reply = node.order(order)
            if not reply.ok:
                log.warning("%s: the task did not start: %s", scenario.file or scenario.name, reply.error)
        node.on_pose = start
    return node


@contextlib.contextmanager
def _taps(bus: Bus, record: Path | None, foxglove: int | None, source: str, report: Callable[[str], None],
          scenario: Scenario, sim: SimConfig | None = None) -> Iterator[Callable[[], None] | None]:
    """While the block runs, car ``vilma``'s topics on ``bus`` (with the world sensors of ``scenario``: cameras,
    laser; and a road's scene, road and traffic, where the simulator of ``sim`` drives it, default: as recorded)
    are recorded to the MCAP file ``record`` with the scenario attached (``scenario.yaml``, as ``vilma run``'s),
    and served to Foxglove on 127.0.0.1:``foxglove`` (each only if given); both are finished when it ends, however
    it ends. Yields the recorder's once-a-second ``tick`` (None when not recording)."""
    world_topics, road = scenario.sim.world_topics, scenario_road(scenario, sim)
    with contextlib.ExitStack() as stack:
        tick = None
        if record is not None:
            recorder = stack.enter_context(Recorder(record, source=source, world_sensors=scenario.sim.world_sensors))
            recorder.add_attachment("scenario.yaml", "application/yaml", to_yaml(scenario).encode())
            tick = stack.enter_context(BusRecorder(bus, recorder, world_topics=world_topics, road=road)).recorder.tick
        if foxglove is not None:
            live = stack.enter_context(FoxgloveLive(bus, port=foxglove, world_topics=world_topics, road=road,
                                                        world_sensors=scenario.sim.world_sensors))
            report(f"Foxglove: open connection ws://127.0.0.1:{live.port}")
        yield tick


def up(scenario: Scenario, speed: float, duration: float, report: Callable[[str], None],
       record: Path | None = None, foxglove: int | None = None) -> int:
    """Simulator and driver in one process on the local bus, paced; prints a line a second.

    With ``record``, every topic is recorded to that MCAP file (finished on SIGINT or SIGTERM too); with
    ``foxglove`` (a port), they are served live to Foxglove.
    """
    with contextlib.ExitStack() as stack:  # everything is closed however the run ends (Ctrl-C, an error)
        bus = stack.enter_context(LocalBus())
        sim = stack.enter_context(Simulator(sim_config(scenario)))
        start = initial_state(scenario, scenario.reference_path())
        sim.reset(start)
        driver = Driver(sim.config.vehicle, scenario.driver, step=sim.config.step)
        sim_node = stack.enter_context(SimNode(sim, bus, start=start))
        stack.enter_context(serve_driver(driver, bus, "vilma", sim.clock.step_ns, scenario))
        tick = stack.enter_context(_taps(bus, record, foxglove, "vilma up", report, scenario, sim.config))
        stop = stack.enter_context(stop_on_signals())
        run_paced(sim, sim_node, speed, duration, stop, lambda: _line(sim, sim_node, driver, tick, report))
    return 0


def _line(sim: Simulator, node: SimNode, driver: Driver, tick: Callable[[], None] | None,
          report: Callable[[str], None]) -> None:
    """``vilma up``'s line a second (the recording's ``tick`` first, if recording)."""
    if tick is not None:
        tick()
    st, s = driver.status, sim.state
    report(f"t {sim.clock.time_s:7.2f} s  x {s.x:8.2f} y {s.y:8.2f} m  speed {s.speed:5.2f} m/s  "
           f"{st.mode}{' arrived' if st.arrived else ''}  off path {st.cross_track:+.3f} m  "
           f"{node.real_time_factor:.2f}x real time")


def sim_program(scenario: Scenario, bus: Bus, speed: float, duration: float, report: Callable[[str], None],
                morse: MorseOptions | None = MorseOptions(), record: Path | None = None,
                foxglove: int | None = None) -> int:
    """``vilma sim``: the simulator serving ``bus`` and the MORSE interface (unless ``morse`` is None), paced,
    until ``duration`` [s], a signal or MORSE's ``simulation quit``. With ``record``, every topic of the car
    on ``bus`` is recorded to that MCAP file; with ``foxglove`` (a port), served live to Foxglove."""
    world = scenario.sim.world_topics
    with contextlib.ExitStack() as stack:  # everything is closed however the run ends (Ctrl-C, an error)
        sim = stack.enter_context(Simulator(sim_config(scenario)))
        start = initial_state(scenario, scenario.reference_path())
        sim.reset(start)
        node = stack.enter_context(SimNode(sim, bus, start=start))
        tick = stack.enter_context(_taps(bus, record, foxglove, "vilma sim", report, scenario, sim.config))
        stop = stack.enter_context(stop_on_signals())
        if morse is not None:
            laser = scenario.sim.laser
            server = MorseServer(
                host=morse.host, service_port=morse.service_port, stream_port=morse.stream_port,
                on_command=node.command, on_reset=node.reset, on_quit=stop.set, time_ns=lambda: sim.time_ns,
                allow_commands_from=morse.allow_commands_from, vehicle=sim.config.vehicle,
                sensors=sim.config.sensors, world_topics=world,
                laser_range=laser.max_range if laser is not None else LASER_RANGE)
            try:
                stack.enter_context(server)
            except ListenError as e:  # what to change, as the command line says it
                raise OSError(f"{MORSE_OPTIONS[e.argument]}: {e.reason}") from None
            node.on_frame, node.on_captures = server.publish, server.publish_captures
            host, port = server.service_address
            first, last = min(server.stream_ports.values()), max(server.stream_ports.values())
            report(f"vilma sim: MORSE services on {host}:{port}, datastreams {first}-{last} "
                   f"(robot vilma: {', '.join(f.split('.', 1)[1] for f in server.stream_ports)})")
        run_paced(sim, node, speed, duration, stop, tick)
    z = sim.state
    report(f"vilma sim: stopped at t={sim.clock.time_s:.2f} s, the car at x={z.x:.2f} y={z.y:.2f} m, "
           f"speed {z.speed:.2f} m/s; commands {node.on_time} on time (within a frame), {node.late} late")
    return 0


def drive_program(scenario: Scenario | None, bus: Bus, report: Callable[[str], None],
                  data_dir: Path | None = None) -> int:
    """``vilma drive``: the self-driver on ``bus`` until stopped; a scenario's task starts on the first pose, and
    follow orders may name the trajectory files in ``data_dir``."""
    params = scenario.driver if scenario is not None else None
    step = scenario.sim.step if scenario is not None else 0.01
    vehicle = scenario.sim.vehicle if scenario is not None else Simulator().config.vehicle
    driver = Driver(vehicle, params, step=step)
    with serve_driver(driver, bus, "vilma", round(step * 1e9), scenario, data_dir) as node, \
            stop_on_signals() as stop:
        while not stop.wait(1.0):
            pass
    report(f"vilma drive: stopped after {node.commands_sent} commands")
    return 0
