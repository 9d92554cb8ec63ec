"""The planner's compiled kernels: the candidates' Cartesian motions, their feasibility and their collisions.

A candidate is a lateral motion ``ci[c]`` of ``lat`` (3, n_lat, n_t: offset d, its rate and acceleration) with a
longitudinal one ``cj[c]`` of ``lon`` (3, n_lon, n_t: arc length s, its rate and acceleration) along the frame
``fa`` (:class:`~vilma.planning.frenet.FrameArrays`). :func:`check_candidates` checks them in an order of
preference until one is free (a planning cycle's work), or all of them (for drawing).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from vilma.planning.frenet import frame_pose, frenet_motion


@njit(cache=True)
def boxes_overlap(ax, ay, ayaw, ahl, ahw, bx, by, byaw, bhl, bhw):
    """Whether two oriented boxes (centre, yaw, half length, half width) overlap: no separating axis among their
    four edge normals (touching counts as overlap)."""
    dx, dy = bx - ax, by - ay
    ca, sa, cb, sb = math.cos(ayaw), math.sin(ayaw), math.cos(byaw), math.sin(byaw)
    for ux, uy in ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb)):
        ra = ahl * abs(ca * ux + sa * uy) + ahw * abs(-sa * ux + ca * uy)
        rb = bhl * abs(cb * ux + sb * uy) + bhw * abs(-sb * ux + cb * uy)
        if abs(dx * ux + dy * uy) > ra + rb:
            return False
    return True


@njit(cache=True)
def _collides(car, x, y, yaw, objects, k, margin):
    """Whether the car at ``(x, y, yaw)`` overlaps any of the object boxes at step ``k``."""
    hl, hw = car.half_length + margin, car.half_width + margin
    cx, cy = x + car.offset * math.cos(yaw), y + car.offset * math.sin(yaw)
    r = math.hypot(hl, hw)
    for o in range(objects.shape[0]):
        ox, oy, oyaw, ol, ow = objects[o, k, 0], objects[o, k, 1], objects[o, k, 2], objects[o, k, 3], objects[o, k, 4]
        reach = r + 0.5 * math.hypot(ol, ow)
        if (ox - cx) ** 2 + (oy - cy) ** 2 > reach * reach:
            continue  # the bounding circles are apart
        if boxes_overlap(cx, cy, yaw, hl, hw, ox, oy, oyaw, 0.5 * ol, 0.5 * ow):
            return True
    return False


@njit(cache=True)
def _reference(fa, lon, j, ref):
    """The reference's pose where longitudinal motion ``j`` is at each step, into ``ref[j]`` (n_t, 7: x, y,
    theta, k, dk and the heading's sine and cosine): shared by every lateral motion."""
    for k in range(lon.shape[2]):
        x, y, theta, kr, dk = frame_pose(fa, lon[0, j, k])
        ref[j, k, 0], ref[j, k, 1], ref[j, k, 2], ref[j, k, 3], ref[j, k, 4] = x, y, theta, kr, dk
        ref[j, k, 5], ref[j, k, 6] = math.sin(theta), math.cos(theta)


@njit(cache=True)
def _motion(ref, lat, lon, edges, i, j, k, car, margin):
    """Step ``k`` of lateral motion ``i`` with longitudinal motion ``j``: (x, y, yaw, speed, accel, curvature,
    whether within the car's limits and, with ``edges`` (2, n_lon, n_t) [m], the road's left and right edges)."""
    theta, kr, dk = ref[j, k, 2], ref[j, k, 3], ref[j, k, 4]
    d = lat[0, i, k]
    s_dot = lon[1, j, k]
    yaw, v, a, kappa = frenet_motion(theta, kr, dk, s_dot, lon[2, j, k], d, lat[1, i, k], lat[2, i, k])
    x, y = ref[j, k, 0] - d * ref[j, k, 5], ref[j, k, 1] + d * ref[j, k, 6]
    ok = True
    if (s_dot < -1e-6 or 1.0 - kr * d <= 0.0 or abs(kappa) > car.max_curvature
            or a > car.max_accel or a < -car.max_decel or abs(kappa) * v * v > car.max_lateral_accel):
        ok = False
    elif edges.shape[1] > 0:  # the box's extent across the reference, against the road's edges
        phi = yaw - theta
        centre = d + car.offset * math.sin(phi)
        half = (car.half_width + margin) * abs(math.cos(phi)) + (car.half_length + margin) * abs(math.sin(phi))
        ok = not (centre + half > edges[0, j, k] or centre - half < edges[1, j, k])
    return x, y, yaw, v, a, kappa, ok


@njit(cache=True)
def check_candidates(fa, lat, lon, edges, ci, cj, order, objects, car, margin, whole, check_all, out, status):
    """Check the candidates in ``order``: each one's Cartesian motion into ``out`` (6, n, n_t: x, y, yaw, speed,
    accel, curvature) and its :class:`~vilma.planning.planner.Status` into ``status`` (n,); the infeasible checked
    for collisions too with ``check_all``. With ``whole``, every candidate at every step (to draw them); otherwise
    only up to the first free one, each up to its first infeasible step or collision (a cycle's choice). The first
    free candidate in ``order`` (-1 if none is)."""
    n_t = lat.shape[2]
    ref = np.empty((lon.shape[1], n_t, 7))
    ready = np.zeros(lon.shape[1], dtype=np.bool_)
    first = -1
    for c in order:
        j = cj[c]
        if not ready[j]:
            _reference(fa, lon, j, ref)
            ready[j] = True
        status[c] = 0
        for k in range(n_t):
            x, y, yaw, v, a, kappa, fits = _motion(ref, lat, lon, edges, ci[c], j, k, car, margin)
            out[0, c, k], out[1, c, k], out[2, c, k], out[3, c, k], out[4, c, k], out[5, c, k] = x, y, yaw, v, a, kappa
            if not fits:
                status[c] = 1
                if not whole:
                    break
        for k in range(n_t if status[c] == 0 or check_all else 0):
            if _collides(car, out[0, c, k], out[1, c, k], out[2, c, k], objects, k, margin):
                status[c] = 2
                break
        if status[c] == 0 and first < 0:
            first = c
            if not whole:
                break
    return first
