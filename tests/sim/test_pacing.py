import pytest

from tests.conftest import physics_only
from vilma.sim import Pacer, Simulator


class FakeWall:
    """A wall clock that moves only when slept on, plus a fixed cost per simulated period."""

    def __init__(self, cost: float = 0.0) -> None:
        self.t, self.cost, self.slept = 100.0, cost, []

    def clock(self) -> float:
        return self.t

    def sleep(self, dt: float) -> None:
        self.slept.append(dt)
        self.t += dt


def _pacer(speed, cost=0.0, period=0.05):
    wall = FakeWall(cost)
    sim = Simulator(physics_only())
    pacer = Pacer(sim, speed=speed, period=period, clock=wall.clock, sleep=wall.sleep)
    return pacer, wall


@pytest.mark.parametrize("speed", [1.0, 4.0, 0.5])
def test_paces_sim_time_to_k_times_wall_time(speed):
    pacer, wall = _pacer(speed)
    stats = pacer.run(2.0)
    assert pacer.sim.time_ns == 2_000_000_000
    assert wall.t - 100.0 == pytest.approx(2.0 / speed)
    assert stats.real_time_factor == pytest.approx(speed)
    assert stats.late == 0 and stats.on_time == 1.0


def test_slow_periods_are_counted_and_re_anchored():
    pacer, wall = _pacer(1.0, period=0.05)

    def costly(_readings):
        wall.t += 0.4 if pacer.stats.periods == 10 else 0.01  # one stall of 0.4 s > max_lag

    stats = pacer.run(1.0, on_period=costly)
    assert stats.late == 1 and stats.slips == 1
    # after the stall it keeps real time from the new anchor instead of racing
    assert wall.t - 100.0 == pytest.approx(1.0 + 0.4 - 0.05, abs=1e-9)


def test_stop_request_ends_the_run():
    pacer, _ = _pacer(1.0)
    stats = pacer.run(10.0, should_stop=lambda: pacer.stats.periods >= 3)
    assert stats.periods == 3 and pacer.sim.time_ns == 150_000_000


@pytest.mark.parametrize("bad", [0.0, -1.0, float("inf"), float("nan")])
def test_bad_speed_rejected(bad):
    with pytest.raises(ValueError, match="speed"):
        Pacer(Simulator(physics_only()), speed=bad)


def test_real_clock_never_runs_ahead_of_real_time():
    stats = Pacer(Simulator(physics_only()), speed=2.0, period=0.02).run(0.4)
    assert stats.real_time_factor <= 2.0 * 1.02
