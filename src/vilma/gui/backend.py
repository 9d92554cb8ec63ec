"""What the GUI talks to: an embedded simulator and driver (local bus, background thread) or a remote bus.

:class:`Embedded` is ``vilma up`` inside the GUI process: the simulator and
the self-driver on a :class:`~vilma.bus.local.LocalBus`, stepped by a
background thread paced to real time (or ``speed`` times it).
:class:`Remote` wraps a bus that reaches ``vilma sim`` / ``vilma drive``
elsewhere (Zenoh). The GUI uses only the bus of either; the embedded one
also lets it swap the driver's controllers live (the bus has no order for
that).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading

from vilma.bus.base import Bus
from vilma.bus.local import LocalBus
from vilma.bus.nodes import DriverNode, SimNode
from vilma.bus.paced import run_paced
from vilma.bus.topics import topic
from vilma.control.driver import Driver, DriverParams
from vilma.core.closing import Closeable
from vilma.core.messages import DriverOrder
from vilma.scenario.fields import load_yaml
from vilma.scenario.orders import plan_setup
from vilma.scenario.runner import initial_state, sim_config
from vilma.scenario.spec import Scenario, parse_scenario
from vilma.sim import Simulator
from vilma.vehicle.params import VehicleParams, vilma

log = logging.getLogger(__name__)


def default_scenario() -> Scenario:
    """The defaults (the paper's car, every sensor) with an idle task: the car waits at the origin."""
    data, src = load_yaml("name: gui\ntask: {speed: 0.0001}", "defaults")
    return parse_scenario(data, src, name="gui")


class Embedded(Closeable):
    """Simulator and driver in this process on a local bus, paced to ``speed`` x real time.

    The scenario gives the car, sensors, start pose, driver parameters and how a
    plan task plans; its task is not started (the GUI gives the orders, Plan its
    plan task). :attr:`world_topics` are the 3D plant's camera and laser topics,
    from the scenario's simulator.
    """

    embedded = True

    def __init__(self, scenario: Scenario | None = None, speed: float = 1.0, car: str = "vilma") -> None:
        if not 0 < speed < math.inf:
            raise ValueError(f"--speed must be a positive factor, got {speed!r}")
        self.scenario = scenario or default_scenario()
        self.speed, self.car = speed, car
        self.world_topics: tuple[str, ...] = self.scenario.sim.world_topics
        self.bus: Bus = LocalBus()
        self.sim = Simulator(sim_config(self.scenario))
        self.start_state = initial_state(self.scenario, self.scenario.reference_path())
        self.sim.reset(self.start_state)
        self.driver_params = self.scenario.driver
        driver = Driver(self.vehicle, self.driver_params, step=self.sim.config.step)
        self.sim_node = SimNode(self.sim, self.bus, car, start=self.start_state)
        self.driver_node = DriverNode(driver, self.bus, car, self.sim.clock.step_ns,
                                      planning=plan_setup(self.scenario))
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: str = ""
        """Why the simulation thread ended, if it failed."""

    @property
    def vehicle(self) -> VehicleParams:
        """The simulated car."""
        return self.sim.config.vehicle

    def describe(self) -> str:
        """One line for the title and the status bar."""
        return f"embedded simulator ({self.scenario.name}), {self.speed:g}x real time"

    def start(self) -> None:
        """Start stepping the simulation in a background thread."""
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="vilma-gui-sim", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        try:
            run_paced(self.sim, self.sim_node, self.speed, math.inf, self._stop)
        except Exception as e:
            log.exception("the embedded simulation stopped")
            self.error = str(e)

    def set_driver_params(self, params: DriverParams) -> None:
        """Swap the driver for one with ``params``; a task under way continues with the new controllers.

        Raises:
            ValueError: the parameters do not fit the simulator (periods, values).
        """
        self.driver_node.set_params(params)
        self.driver_params = params

    def stop(self) -> None:
        """Stop the simulation thread (within a frame)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None

    @property
    def running(self) -> bool:
        """Whether the simulation thread is stepping."""
        return self._thread is not None and self._thread.is_alive()

    def close(self) -> None:
        """Stop the simulation and release the bus (closing again does nothing)."""
        self.stop()
        self.driver_node.close()
        self.sim_node.close()
        self.sim.close()
        self.bus.close()


class Remote(Closeable):
    """A bus that reaches a simulator and a driver in other processes (``vilma sim`` / ``vilma drive``);
    ``world_topics``: that simulator's camera and laser topics (its scenario's); ``scenario``: the one they run,
    if known (its road is drawn, its plan task can be ordered)."""

    embedded = False

    def __init__(self, bus: Bus, where: str = "Zenoh", car: str = "vilma", world_topics: tuple[str, ...] = (),
                 driver_params: DriverParams | None = None, scenario: Scenario | None = None) -> None:
        self.bus, self.where, self.car = bus, where, car
        self.world_topics = tuple(world_topics)
        self.vehicle = vilma()
        self.driver_params = driver_params or DriverParams()
        """What the remote driver runs, as far as this GUI knows (its scenario's, then what was set)."""
        self.scenario = scenario

    def describe(self) -> str:
        """One line for the title and the status bar."""
        return f"connected to {self.where}"

    def start(self) -> None:
        """Nothing to start: the simulator runs elsewhere."""

    def set_driver_params(self, params: DriverParams) -> None:
        """Send the driver a ``tune`` order with the controllers and gains of ``params``.

        Raises:
            ValueError: the driver refused them, or did not answer.
        """
        names = (params.speed_controller, params.path_controller)
        reply = self.bus.request(topic("driver/cmd", self.car), DriverOrder(
            action="tune", speed_controller=names[0], path_controller=names[1],
            gains={name: dataclasses.asdict(params.gains_of(name)) for name in names}))
        if not reply.ok:
            raise ValueError(reply.error)
        self.driver_params = params

    def close(self) -> None:
        """Close the bus (closing again does nothing)."""
        self.bus.close()

