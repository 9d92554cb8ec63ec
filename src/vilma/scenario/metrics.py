"""The scorecard of a run (``metrics.json``): stable keys, SI units, ``None`` where a key does not apply.

Measured on the plant's true motion at every control period (not on what the
driver believed), against the reference path by projection from the centre of
mass. Path and speed-tracking errors are counted after ``MetricsSpec.skip``
seconds. The speed-step keys (rise, overshoot, settling, steady state) apply to
a ``speed`` task, a constant target from rest, as the paper's Figure 11.
``controller_time_per_step_us`` is the mean wall time of the driver per period;
in the compiled loop, of the whole loop per period (an upper bound).
"""

from __future__ import annotations

import math

import numpy as np

from vilma.core.geometry import wrap_angle
from vilma.scenario.drive_log import DriveLog
from vilma.scenario.spec import SCORECARD_KEYS, Bound, Scenario
from vilma.trajectory import Trajectory


def scorecard(log: DriveLog, scenario: Scenario, path: Trajectory | None, t_start: float, completed: bool,
              wall_time: float) -> dict:
    """The scorecard of a drive: ``t_start`` [s] is when the task began, ``wall_time`` [s] what it took."""
    c = log.column
    t, x, y, yaw = c("t"), c("x"), c("y"), c("yaw")
    speed = np.hypot(c("vx"), c("vy")) * np.sign(c("vx"))
    m = scenario.metrics
    counted = t >= t_start + m.skip
    sim_time = float(t[-1]) if len(t) else 0.0
    out: dict = dict.fromkeys(SCORECARD_KEYS)
    out.update(completed=bool(completed), sim_time_s=sim_time, wall_time_s=wall_time,
               realtime_factor=sim_time / wall_time if wall_time > 0 else None,
               distance_m=float(np.sum(np.hypot(np.diff(x), np.diff(y)))))
    if path is not None and counted.any():
        proj = path.project_track(np.column_stack([x, y]))
        e = np.abs(proj[counted, 1])
        out.update(lateral_error_rms_m=_rms(e), lateral_error_max_m=float(e.max()),
                   lateral_error_p95_m=float(np.percentile(e, 95)),
                   heading_error_rms_rad=_rms(wrap_angle(yaw[counted] - proj[counted, 2])))
    if counted.any():
        out["speed_error_rms_mps"] = _rms(speed[counted] - c("target_speed")[counted])
    if scenario.task.kind == "speed":
        out.update(step_response(t - t_start, speed, scenario.task.speed, m.settle_band, m.steady_window))
    if len(t) > 2:
        dt = np.diff(t)
        out["steering_rate_rms_radps"] = _rms(np.diff(c("steer")) / dt)
        a_long, a_lat = _accelerations(t, yaw, c("vx"), c("vy"))
        out["lateral_accel_max_mps2"] = float(np.abs(a_lat).max())
        if len(a_long) > 1:
            out["longitudinal_jerk_rms_mps3"] = _rms(np.diff(a_long) / dt[1:])
    if scenario.driver.pose_source != "truth":
        est = ~np.isnan(c("est_x"))
        if est.any():
            out["pose_error_rms_m"] = _rms(np.hypot(c("est_x")[est] - x[est], c("est_y")[est] - y[est]))
    us = c("controller_us")
    if len(us):
        out["controller_time_per_step_us"] = float(np.mean(us))
    return {k: _plain(v) for k, v in out.items()}


def _rms(a: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def _plain(v):
    """JSON-ready: NaN and infinity become None (a key that cannot be measured), numpy scalars floats."""
    if isinstance(v, bool) or v is None:
        return v
    v = float(v)
    return v if math.isfinite(v) else None


def _accelerations(t, yaw, vx, vy) -> tuple[np.ndarray, np.ndarray]:
    """Longitudinal and lateral acceleration [m/s^2] between samples, from the world-frame velocity."""
    c, s = np.cos(yaw), np.sin(yaw)
    wx, wy = vx * c - vy * s, vx * s + vy * c
    dt = np.diff(t)
    ax, ay = np.diff(wx) / dt, np.diff(wy) / dt
    mid = yaw[:-1] + 0.5 * wrap_angle(np.diff(yaw))
    cm, sm = np.cos(mid), np.sin(mid)
    return ax * cm + ay * sm, -ax * sm + ay * cm


def step_response(t: np.ndarray, v: np.ndarray, target: float, band: float, window: float) -> dict:
    """Rise time to 90 %, overshoot, settling time into +-``band`` and steady-state error of a speed step."""
    after = t >= 0
    t, v = t[after], v[after]
    out = {}
    reached = np.nonzero(v >= 0.9 * target)[0]
    if len(reached):
        i = reached[0]
        out["speed_rise_time_90_s"] = float(t[i] if i == 0 else
                                            np.interp(0.9 * target, [v[i - 1], v[i]], [t[i - 1], t[i]]))
    out["speed_overshoot_pct"] = float(max(0.0, (v.max() / target - 1.0) * 100.0)) if len(v) else None
    outside = np.nonzero(np.abs(v - target) > band * target)[0]
    if len(v) and (not len(outside) or outside[-1] < len(v) - 1):
        out["speed_settling_time_2pct_s"] = float(t[outside[-1] + 1]) if len(outside) else float(t[0])
    tail = t >= t[-1] - window if len(t) else after
    if len(t):
        out["speed_steady_state_error_mps"] = float(abs(np.mean(v[tail]) - target))
    return out


def check_expectations(metrics: dict, expect: dict[str, Bound | bool]) -> list[str]:
    """The pass criteria a scorecard fails, one line each (empty: it passes)."""
    failed = []
    for key, want in expect.items():
        got = metrics.get(key)
        if isinstance(want, bool):
            if got is not want:
                failed.append(f"{key}: expected {str(want).lower()}, got {got}")
        elif not want.check(got):
            lims = " and ".join(f"{n} {v:g}" for n, v in (("min", want.min), ("max", want.max)) if v is not None)
            failed.append(f"{key}: {got if got is None else f'{got:.4g}'} is outside {lims}")
    return failed
