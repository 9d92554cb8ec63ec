"""Reactive traffic (``traffic: reactive``): each recorded car keeps its recorded path but sets its speed along it
with the Intelligent Driver Model behind the nearest car ahead on that path, the ego included.

M. Treiber, A. Hennecke, D. Helbing, "Congested traffic states in empirical observations and microscopic
simulations", Phys. Rev. E 62, 1805 (2000): ``a = a_max [1 - (v/v0)^delta - (s*/s)^2]`` with the desired gap
``s* = s0 + max(0, v T + v dv / (2 sqrt(a_max b)))``, ``s`` the bumper-to-bumper gap and ``dv`` the closing speed.
Integrated with the ballistic update (speed never below 0) at the driver period, in Python beside the loop.
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
    free road) and closing speed ``dv`` [m/s] to the leader."""
    s_star = p.s0 + np.maximum(0.0, v * p.T + v * dv / (2 * math.sqrt(p.a_max * p.b)))
    with np.errstate(divide="ignore"):
        return p.a_max * (1 - (v / v0) ** p.delta - (s_star / np.maximum(gap, 1e-3)) ** 2)


class ReactiveTraffic:
    """The scenario's traffic driven by IDM along the recorded paths: :attr:`traffic` holds the states at every
    driver period from sim time 0 (dt = ``period``), filled one period ahead by :meth:`step`.

    Args:
        recorded: the recorded traffic.
        t0: the recording's time at sim time 0 [s].
        period: the driver period [s]; ``periods`` how many the run may last.
        ego_length: the ego's length [m] (its box centre is the point :meth:`step` gets).
    """

    def __init__(self, recorded: Traffic, t0: float, period: float, periods: int, ego_length: float,
                 params: IdmParams = IdmParams()) -> None:
        self.params, self.recorded, self.t0, self.period = params, recorded, t0, period
        m, k = recorded.present.shape
        self._ego_half = ego_length / 2
        self._half = (recorded.outline[..., 0].max(axis=1) - recorded.outline[..., 0].min(axis=1)) / 2
        self._moving = ~recorded.static & recorded.present.any(axis=1)
        first = np.where(self._moving, recorded.present.argmax(axis=1), 0)
        last = np.where(self._moving, k - 1 - recorded.present[:, ::-1].argmax(axis=1), 0)
        self._appear = first * recorded.dt
        # the paths: the recorded positions from the first to the last recorded step, held after the last
        idx = np.clip(np.arange(k)[None, :], first[:, None], last[:, None])
        self._xy = np.take_along_axis(recorded.states[..., [X, Y]], idx[..., None], axis=1)
        self._yaw = np.unwrap(np.take_along_axis(recorded.states[..., YAW], idx, axis=1), axis=1)
        self._speed = np.take_along_axis(recorded.states[..., V], idx, axis=1)
        seg = np.hypot(*np.diff(self._xy, axis=1).transpose(2, 0, 1))
        self._arc = np.concatenate([np.zeros((m, 1)), np.cumsum(seg, axis=1)], axis=1)
        self._s, self._v = np.zeros(m), self._speed[:, 0].copy()
        states, present = np.zeros((m, periods + 2, 4)), np.zeros((m, periods + 2), bool)
        states[:], present[:] = recorded.at(t0)[0][:, None], recorded.at(t0)[1][:, None]  # row 0; static ones stay
        self.traffic = replace(recorded, states=states, present=present, dt=period)
        self._j = 0
        self._place(0)

    def step(self, ego_x: float, ego_y: float, ego_speed: float) -> None:
        """Fill the next period's states from this one's, the ego's box centre at ``ego_x, ego_y`` [m] moving at
        ``ego_speed`` [m/s] now (explicit: the traffic reacts to what it sees at the period's start)."""
        j, p, dt = self._j, self.params, self.period
        if j + 1 >= self.traffic.states.shape[1]:
            return
        row, seen = self.traffic.states[:, j], self.traffic.present[:, j]
        t = self.t0 + j * dt
        gap, lead_v = self._leaders(np.vstack([row[:, [X, Y]], [[ego_x, ego_y]]]),
                                    np.append(row[:, V], ego_speed), np.append(seen, True),
                                    np.append(self._half, self._ego_half))
        v0 = np.maximum(self._along(self._speed, self._s + p.s0), 0.1)
        a = idm_acceleration(p, self._v, v0, gap, self._v - lead_v)
        driving = self._moving & (t >= self._appear)
        v1 = np.maximum(self._v + a * dt, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            ds = np.where(self._v + a * dt >= 0, (self._v + v1) / 2 * dt, -self._v ** 2 / (2 * a))
        self._s, self._v = np.where(driving, self._s + ds, self._s), np.where(driving, v1, self._v)
        self._j = j + 1
        self._place(j + 1)

    def _place(self, j: int) -> None:
        """Row ``j`` of the moving cars' states from their arc positions and speeds."""
        st, t = self.traffic.states[:, j], self.t0 + j * self.period
        n = self._moving
        st[n, X], st[n, Y] = self._along(self._xy[..., 0], self._s)[n], self._along(self._xy[..., 1], self._s)[n]
        st[n, YAW] = (self._along(self._yaw, self._s)[n] + math.pi) % (2 * math.pi) - math.pi
        st[n, V] = self._v[n]
        # on the road from its first recorded time until it has driven its whole path
        self.traffic.present[n, j] = (t >= self._appear[n] - 1e-9) & (self._s[n] < self._arc[n, -1] - 1e-6)

    def _along(self, values: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Each path's ``values`` (m, k) at arc lengths ``s`` (m,) [m], linearly between the recorded points."""
        return np.array([np.interp(si, a, v) for si, a, v in zip(s, self._arc, values, strict=True)])

    def _leaders(self, xy: np.ndarray, v: np.ndarray, seen: np.ndarray, half: np.ndarray):
        """Each car's bumper gap [m] (inf: none) and speed [m/s] of the nearest of the bodies at ``xy`` (c, 2)
        ahead on its path within half a lane of it."""
        a, d = self._xy[:, None, :-1], np.diff(self._xy, axis=1)[:, None]  # (m, 1, k-1, 2)
        rel = xy[None, :, None] - a  # (m, c, k-1, 2)
        length2 = np.maximum((d ** 2).sum(-1), 1e-12)
        f = np.clip((rel * d).sum(-1) / length2, 0.0, 1.0)
        dist = np.hypot(*(rel - f[..., None] * d).transpose(3, 0, 1, 2))
        i = dist.argmin(axis=2)  # (m, c): the nearest segment
        lateral = np.take_along_axis(dist, i[..., None], 2)[..., 0]
        ahead = np.take_along_axis(self._arc[:, :-1], i, 1) + np.take_along_axis(f, i[..., None], 2)[..., 0] * \
            np.sqrt(np.take_along_axis(length2[:, 0], i, 1)) - self._s[:, None]
        m = len(self._s)
        ok = seen[None, :] & (lateral <= self.params.lane_width / 2) & (ahead > 0)
        ok[np.arange(m), np.arange(m)] = False
        gaps = np.where(ok, ahead - self._half[:, None] - half[None, :], np.inf)
        k = gaps.argmin(axis=1)
        return gaps[np.arange(m), k], np.where(np.isfinite(gaps[np.arange(m), k]), v[k], 0.0)

    def task(self, task: EgoTask) -> EgoTask:
        """``task`` with the traffic where it was driven (at the file's time steps from the initial state), for
        the benchmark's checks."""
        sc = task.scenario
        out = Scenario(dt=sc.dt, scenario_id=sc.scenario_id)
        out.add_objects(sc.lanelet_network)
        steps, m, tr = int((self._j * self.period) / sc.dt + 1e-9) + 1, len(self._s), self.traffic
        pose, seen = np.empty((steps, m, 4)), np.empty((steps, m), bool)
        for k in range(steps):
            states_at(tr.states, tr.present, tr.static, tr.dt, k * sc.dt, pose[k], seen[k])
        for n, o in enumerate(sc.obstacles):
            if not self._moving[n]:
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
