import numpy as np
import pytest

from tests.conftest import physics_only
from vilma.core.messages import ActuatorCommand
from vilma.sim import Simulator
from vilma.vehicle.state import VehicleState


def _end(step, integrator="rk4"):
    sim = Simulator(physics_only(step=step, integrator=integrator))
    sim.reset(VehicleState(vx=15.0, steer=0.1, drive_force=1500.0))  # actuators settled: only the ODE is tested
    sim.command(ActuatorCommand(steer=0.1, drive=1500.0))
    sim.run_for(3.0)
    return sim._z[:6].copy()


def test_rk4_converges_at_fourth_order_and_beats_euler():
    ref = _end(0.0005)
    e10, e5 = (np.linalg.norm(_end(s)[:2] - ref[:2]) for s in (0.01, 0.005))
    # halving the step cuts a 4th-order error about 16x
    assert e10 / e5 > 8.0
    assert np.linalg.norm(_end(0.005, "euler")[:2] - ref[:2]) > 10 * e5


@pytest.mark.parametrize("bad", [{"step": 0.02}, {"step": 0.0}, {"model": "tank"}, {"integrator": "rk45"},
                                 {"watchdog_timeout": -1.0}])
def test_bad_config_is_rejected(bad):
    with pytest.raises(ValueError):
        physics_only(**bad)
