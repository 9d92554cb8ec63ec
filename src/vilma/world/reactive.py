"""Reactive traffic (``traffic: reactive``): each recorded car keeps its recorded path but sets its speed along it
with the Intelligent Driver Model behind the nearest car ahead on that path, the ego included.

M. Treiber, A. Hennecke, D. Helbing, "Congested traffic states in empirical observations and microscopic
simulations", Phys. Rev. E 62, 1805 (2000): ``a = a_max [1 - (v/v0)^delta - (s*/s)^2]`` with the desired gap
``s* = s0 + max(0, v T + v dv / (2 sqrt(a_max b)))``, ``s`` the bumper-to-bumper gap and ``dv`` the closing speed.
Integrated with the ballistic update (speed never below 0) at the driver period, compiled
(:func:`vilma.world.idm.idm_step`): from Python beside the loop, or inside the compiled closed loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from commonroad.prediction.prediction import TrajectoryPrediction
from commonroad.scenario.obstacle import DynamicObstacle
from commonroad.scenario.scenario import Scenario
from commonroad.scenario.state import CustomState, InitialState
from commonroad.scenario.trajectory import Trajectory

from vilma.world.commonroad import EgoTask
from vilma.world.idm import IdmArrays, acceleration, chunk_bounds, idm_step, place
from vilma.world.states import YAW, V, X, Y, states_at
from vilma.world.traffic import Traffic, traffic


@dataclass(frozen=True, slots=True, kw_only=True)
class IdmParams:
    """The Intelligent Driver Model's parameters (Treiber et al. 2000; its table I's city-traffic values)."""

    a_max: float = 1.0
    """Maximum acceleration [m/s^2]."""
    b: float = 1.5
    """Comfortable deceleration [m/s^2]."""
    T: float = 1.0
    """Safe time headway [s]."""
    s0: float = 2.0
    """Gap at a standstill [m]."""
    delta: float = 4.0
    """Acceleration exponent."""
    lane_width: float = 3.5
    """A car is ahead on a path when its centre lies within half this [m] of the path."""


def idm_acceleration(p: IdmParams, v: np.ndarray, v0: np.ndarray, gap: np.ndarray, dv: np.ndarray) -> np.ndarray:
    """IDM's acceleration [m/s^2] at speed ``v`` [m/s], desired speed ``v0`` [m/s], bumper gap ``gap`` [m] (inf:
    free road) and closing speed ``dv`` [m/s] to the leader (:func:`vilma.world.idm.acceleration`)."""
    c = _consts(p, 0.0, 0.0, 0.0)
    return np.array([acceleration(c, *x) for x in zip(v, v0, gap, dv, strict=True)])


def _consts(p: IdmParams, ego_half: float, t0: float, period: float) -> np.ndarray:
    """:attr:`IdmArrays.consts <vilma.world.idm.IdmArrays.consts>`."""
    return np.array([p.a_max, p.b, p.T, p.s0, p.delta, p.lane_width, ego_half, t0, period])


RING = 60.0
"""Sim time [s] the traffic of an open-ended run keeps (:attr:`Traffic.ring <vilma.world.traffic.Traffic.ring>`):
its readers (sensors, views, recordings) look at the present or a moment before."""


class ReactiveTraffic:
    """The scenario's traffic driven by IDM along the recorded paths: :attr:`traffic` holds the states at every
    driver period from sim time 0 (dt = ``period``), filled one period ahead by :meth:`step` (or by the compiled
    closed loop, with :attr:`arrays`): the simulator does both (:attr:`SimConfig.reactive
    <vilma.sim.config.SimConfig.reactive>`).

    Args:
        recorded: the recorded traffic.
        t0: the recording's time at sim time 0 [s].
        period: the driver period [s]; ``periods`` how many the run may last (None: open-ended; the traffic then
            keeps the last :data:`RING` seconds, a ring).
        ego_length: the ego's length [m] (its box centre is the point :meth:`step` gets).
    """

    def __init__(self, recorded: Traffic, t0: float, period: float, periods: int | None, ego_length: float,
                 params: IdmParams = IdmParams()) -> None:
        self.params, self.recorded, self.t0, self.period = params, recorded, t0, period
        m, k = recorded.present.shape
        moving = ~recorded.static & recorded.present.any(axis=1)
        first = np.where(moving, recorded.present.argmax(axis=1), 0)
        last = np.where(moving, k - 1 - recorded.present[:, ::-1].argmax(axis=1), 0)
        # the paths: the recorded positions from the first to the last recorded step, held after the last
        idx = np.clip(np.arange(k)[None, :], first[:, None], last[:, None])
        x, y, yaw, speed = (np.take_along_axis(recorded.states[..., c], idx, axis=1) for c in (X, Y, YAW, V))
        arc = np.concatenate([np.zeros((m, 1)), np.cumsum(np.hypot(np.diff(x), np.diff(y)), axis=1)], axis=1)
        rows = periods + 2 if periods is not None else math.ceil(RING / period) + 2
        states, present = np.zeros((m, rows, 4)), np.zeros((m, rows), bool)
        states[:], present[:] = recorded.at(t0)[0][:, None], recorded.at(t0)[1][:, None]  # row 0; static ones stay
        self.traffic = replace(recorded, states=states, present=present, dt=period, ring=periods is None)
        half = (recorded.outline[..., 0].max(axis=1) - recorded.outline[..., 0].min(axis=1)) / 2
        self.arrays = IdmArrays(
            _consts(params, ego_length / 2, t0, period), half, moving, first * recorded.dt, x, y,
            np.unwrap(yaw, axis=1), speed, arc, chunk_bounds(x, y),
            np.zeros(m), speed[:, 0].copy(), states, present, np.zeros(1, np.int64))
        """What :func:`~vilma.world.idm.idm_step` works on (the ``traffic``'s states among them)."""
        self.reset()

    def reset(self) -> None:
        """Back to sim time 0: each car at its recording's start, at its recorded speed there."""
        a = self.arrays
        a.s[:], a.v[:], a.j[0] = 0.0, a.speed[:, 0], 0
        place(a, 0)

    def step(self, ego_x: float, ego_y: float, ego_speed: float) -> None:
        """Fill the next period's states from this one's, the ego's box centre at ``ego_x, ego_y`` [m] moving at
        ``ego_speed`` [m/s] now (explicit: the traffic reacts to what it sees at the period's start)."""
        idm_step(self.arrays, float(ego_x), float(ego_y), float(ego_speed))

    def task(self, task: EgoTask) -> EgoTask:
        """``task`` with the traffic where it was driven (at the file's time steps from the initial state), for
        the benchmark's checks."""
        sc = task.scenario
        out = Scenario(dt=sc.dt, scenario_id=sc.scenario_id)
        out.add_objects(sc.lanelet_network)
        steps, m, tr = int((int(self.arrays.j[0]) * self.period) / sc.dt + 1e-9) + 1, len(self.arrays.s), self.traffic
        pose, seen = np.empty((steps, m, 4)), np.empty((steps, m), bool)
        for k in range(steps):
            states_at(tr.states, tr.present, tr.static, tr.dt, k * sc.dt, pose[k], seen[k])
        for n, o in enumerate(sc.obstacles):
            if not self.arrays.moving[n]:
                out.add_objects(o)
                continue
            states = [CustomState(time_step=task.time_step + k, position=pose[k, n, [X, Y]],
                                  orientation=float(pose[k, n, YAW]), velocity=float(pose[k, n, V]))
                      for k in np.flatnonzero(seen[:, n]).tolist()]
            if len(states) > 1:
                init = InitialState(**{a: getattr(states[0], a) for a in ("time_step", "position", "orientation",
                                                                            "velocity")}, acceleration=0.0,
                                    yaw_rate=0.0, slip_angle=0.0)
                out.add_objects(DynamicObstacle(o.obstacle_id, o.obstacle_type, o.obstacle_shape, init,
                                                TrajectoryPrediction(Trajectory(init.time_step + 1, states[1:]),
                                                                     o.obstacle_shape)))
        return replace(task, scenario=out, traffic=traffic(out))
