"""Reactive traffic against the Intelligent Driver Model's own law (Treiber et al. 2000): a car stops s0 behind a
standing one, and on a free road speeds up as dv/dt = a_max (1 - (v/v0)^4) says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vilma.world import reactive
from vilma.world.reactive import IdmParams, ReactiveTraffic, idm_acceleration
from vilma.world.traffic import Traffic

DT = 0.1  # the recording's time step [s]
PERIOD = 0.02  # the driver period the traffic is stepped at [s]
LENGTH = 4.0  # each car's length [m]
FAR = (0.0, 1000.0)  # an ego nowhere near the lane [m]


def _box(n: int) -> np.ndarray:
    return np.tile([[LENGTH / 2, -1.0], [LENGTH / 2, 1.0], [-LENGTH / 2, 1.0], [-LENGTH / 2, -1.0]], (n, 1, 1))


def _lane(speed: np.ndarray, standing_at: float | None = None) -> Traffic:
    """A car recorded along +x from x = 0 at ``speed`` (k,) [m/s] at each step, and, if ``standing_at`` [m], a
    static car standing there in its lane."""
    k = len(speed)
    x = np.concatenate([[0.0], np.cumsum(np.full(k - 1, 15.0 * DT))])  # its path, 15 m/s apart
    states = np.zeros((1, k, 4))
    states[0, :, 0], states[0, :, 3] = x, speed
    present, static = np.ones((1, k), bool), np.array([False])
    if standing_at is not None:
        still = np.zeros((1, k, 4))
        still[0, :, 0] = standing_at
        states, present = np.concatenate([states, still]), np.ones((2, k), bool)
        static = np.array([False, True])
    return Traffic(ids=np.arange(len(static)), static=static, outline=_box(len(static)), states=states,
                   present=present, dt=DT)


def _idm_stop(p: IdmParams, gap: float, v: float, v0: float, dt: float) -> tuple[float, float]:
    """The gap [m] at which a car at ``v`` [m/s] ``gap`` [m] behind a standing one comes to rest, and the smallest
    on the way, by IDM's formula integrated at ``dt`` [s] (ballistic, speed never below 0)."""
    smallest = gap
    while True:
        s_star = p.s0 + max(0.0, v * p.T + v * v / (2 * math.sqrt(p.a_max * p.b)))
        a = p.a_max * (1 - (v / v0) ** p.delta - (s_star / gap) ** 2)
        if v + a * dt <= 0:
            return gap - v * v / (-2 * a), min(smallest, gap - v * v / (-2 * a))
        gap -= (v + a * dt / 2) * dt
        v += a * dt
        smallest = min(smallest, gap)


def test_a_car_behind_a_standing_one_stops_near_s0_behind_it_without_touching():
    p = IdmParams()
    leader, v0 = 100.0, 15.0
    rt = ReactiveTraffic(_lane(np.full(301, v0), standing_at=leader), 0.0, PERIOD, 6000, ego_length=LENGTH)
    gaps = []
    for j in range(1, 6001):  # 120 s
        rt.step(*FAR, 0.0)
        x = rt.traffic.states[0, j, 0]
        gaps.append((leader - LENGTH / 2) - (x + LENGTH / 2))
    rest, smallest = _idm_stop(p, leader - LENGTH, v0, v0, PERIOD / 20)
    # at rest IDM's acceleration is a_max (1 - (s0/s)^2): a car rests only at a gap s <= s0 (+ v T, v = 0); the
    # approach from speed comes to rest a little short of s0, as the model's own equation has it
    assert rest <= p.s0 and rest > 0.8 * p.s0
    assert gaps[-1] == pytest.approx(rest, abs=0.01)
    assert min(gaps) >= smallest - 0.01 and min(gaps) > 0  # no collision
    assert rt.traffic.states[0, 6000, 3] == 0.0


def test_on_a_free_road_a_car_speeds_up_by_idms_acceleration_law():
    p, v0 = IdmParams(), 15.0
    speed = np.full(601, v0)
    speed[0] = 0.0  # recorded setting off from rest
    rt = ReactiveTraffic(_lane(speed), 0.0, PERIOD, 2000, ego_length=LENGTH)
    t, v = [], []
    for j in range(1, 2001):
        rt.step(*FAR, 0.0)
        t.append(j * PERIOD)
        v.append(rt.traffic.states[0, j, 3])
    t, v = np.array(t), np.array(v)
    # dv/dt = a (1 - u^4), u = v/v0, integrates to t(v) = v0 / (2 a) (atanh u + atan u)
    u = v / v0
    rising = u < 0.95
    expected = v0 / (2 * p.a_max) * (np.arctanh(u[rising]) + np.arctan(u[rising]))
    np.testing.assert_allclose(t[rising], expected, atol=2 * PERIOD)
    assert v[-1] == pytest.approx(v0, rel=0.01) and v.max() <= v0


def test_idm_acceleration_is_the_papers_formula():
    p = IdmParams()
    v, v0, gap, dv = 10.0, 20.0, 30.0, 2.0
    s_star = p.s0 + v * p.T + v * dv / (2 * math.sqrt(p.a_max * p.b))
    want = p.a_max * (1 - (v / v0) ** 4 - (s_star / gap) ** 2)
    assert idm_acceleration(p, np.array([v]), np.array([v0]), np.array([gap]), np.array([dv]))[0] == pytest.approx(
        want)
    assert idm_acceleration(p, np.array([0.0]), np.array([v0]), np.array([math.inf]), np.array([0.0]))[0] == p.a_max


def test_an_open_ended_run_keeps_the_last_ring_seconds_and_drives_as_a_sized_one(monkeypatch):
    monkeypatch.setattr(reactive, "RING", 1.0)
    lane, periods = _lane(np.full(301, 15.0), standing_at=100.0), 1000  # 20 s: 20 laps of the ring
    sized = ReactiveTraffic(lane, 0.0, PERIOD, periods, ego_length=LENGTH)
    ring = ReactiveTraffic(lane, 0.0, PERIOD, None, ego_length=LENGTH)
    assert ring.traffic.ring and ring.traffic.states.shape[1] == math.ceil(1.0 / PERIOD) + 2
    for j in range(periods):
        for rt in (sized, ring):
            rt.step(*FAR, 0.0)
        # the last second (and the period ahead), between the periods too, as the sensors and the views read it
        for t in np.arange(max(j - 49, 0), j + 1.5, 0.5) * PERIOD:
            for got, want in zip(ring.traffic.at(t), sized.traffic.at(t), strict=True):
                assert np.array_equal(got, want)
