"""The anchor of ``benchmarks/whole_command.py``: the drive of ``vilma run course_30kmh_stanley`` as a user would
write it by hand in plain Python and numpy, with nothing of vilma.

The same course (a natural cubic spline through the same points, a point every 0.5 m), the same car (a
single-track model with linear tyres, the vilma car's mass, inertia, axle distances and cornering stiffnesses),
Stanley steering on the front axle every 20 ms (gain 5, softening 1 m/s), a PI speed law every 40 ms (kp 1.2,
ki 0.3) at 30 km/h, a 10 ms Euler step, stopping at the path's end; a log row every 20 ms written as CSV.

    python benchmarks/anchors/numpy_stanley.py OUT.csv
"""

from __future__ import annotations

import math
import sys

import numpy as np
from scipy.interpolate import CubicSpline

POINTS = np.array([(0.0, 0.0), (100.0, 0.0), (100.0, -30.0), (50.0, -20.0), (60.0, 0.0)])
M, IZ, LF, LR, CF, CR = 1211.0, 1798.335, 1.1, 1.35, 75000.0, 110000.0
SPEED, DT, MAX_STEER, MAX_FORCE = 8.3333, 0.01, 0.6, 6000.0


def course() -> np.ndarray:
    u = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(POINTS, axis=0).T))])
    return CubicSpline(u, POINTS, bc_type="natural")(np.linspace(0.0, u[-1], round(u[-1] / 0.5) + 1))


def drive(path: np.ndarray) -> list[tuple[float, ...]]:
    seg = np.diff(path, axis=0)
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    x, y, yaw, vx, vy, r = path[0, 0], path[0, 1], heading[0], 0.0, 0.0, 0.0
    steer = force = integral = 0.0
    rows, t, i = [], 0.0, 0
    while t < 120.0:
        k = round(t / DT)
        if k % 2 == 0:  # Stanley at 20 ms on the front axle
            fx, fy = x + LF * math.cos(yaw), y + LF * math.sin(yaw)
            lo, hi = max(i - 40, 0), min(i + 40, len(seg))
            d = np.hypot(path[lo:hi + 1, 0] - fx, path[lo:hi + 1, 1] - fy)
            i = min(lo + int(np.argmin(d)), len(seg) - 1)
            if i >= len(seg) - 1 and vx < 0.05:
                break
            e = -(fx - path[i, 0]) * math.sin(heading[i]) + (fy - path[i, 1]) * math.cos(heading[i])
            psi = (heading[i] - yaw + math.pi) % (2 * math.pi) - math.pi
            steer = max(-MAX_STEER, min(MAX_STEER, psi - math.atan2(5.0 * e, 1.0 + vx)))
            rows.append((t, x, y, yaw, vx, steer, force))
        if k % 4 == 0:  # PI speed at 40 ms, braking to a stop on the last 10 m
            left = (len(seg) - 1 - i) * 0.5
            target = min(SPEED, math.sqrt(2 * 2.0 * max(left, 0.0)))
            err = target - vx
            integral += err * 4 * DT
            force = max(-2 * MAX_FORCE, min(MAX_FORCE, M * (1.2 * err + 0.3 * integral)))
        if vx > 0.5:  # linear tyres
            af, ar = steer - math.atan2(vy + LF * r, vx), -math.atan2(vy - LR * r, vx)
            fyf, fyr = CF * af, CR * ar
        else:
            fyf = fyr = 0.0
        ax = force / M + vy * r
        ay = (fyf * math.cos(steer) + fyr) / M - vx * r
        rr = (LF * fyf * math.cos(steer) - LR * fyr) / IZ
        x += (vx * math.cos(yaw) - vy * math.sin(yaw)) * DT
        y += (vx * math.sin(yaw) + vy * math.cos(yaw)) * DT
        yaw += r * DT
        vx, vy, r = max(vx + ax * DT, 0.0), vy + ay * DT, r + rr * DT
        t += DT
    return rows


if __name__ == "__main__":
    rows = drive(course())
    np.savetxt(sys.argv[1], np.array(rows), delimiter=",", header="t,x,y,yaw,vx,steer,force", comments="")
    print(f"{rows[-1][0]:.2f} s driven, final error at the end: "
          f"{math.hypot(rows[-1][1] - POINTS[-1, 0], rows[-1][2] - POINTS[-1, 1]):.2f} m")
