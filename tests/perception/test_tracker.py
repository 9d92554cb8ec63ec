"""The tracker against targets of known motion: its filter converges to the Riccati equation's steady state, its
velocity error within what that covariance allows, identities kept through a crossing, tracks born after M hits
of N scans and dropped after K misses."""

from __future__ import annotations

import dataclasses
import math
from itertools import pairwise

import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

from tests.perception.conftest import SICK, boxes, scan
from vilma.perception.boxes import fit_boxes, laser_pose
from vilma.perception.metrics import MotFrame, clear_mot
from vilma.perception.segment import SegmentParams, scan_points, segment
from vilma.perception.tracker import Tracker, TrackerParams

DT_NS = 100_000_000  # scans at 10 Hz
DT = DT_NS * 1e-9


def box(x: float, y: float, yaw: float = 0.0, length: float = 4.5, width: float = 1.8) -> list[float]:
    return [x, y, yaw, length, width]


def steady_covariance(p: TrackerParams) -> np.ndarray:
    """The constant-velocity Kalman filter's covariance after an update in the steady state (4, 4): the discrete
    algebraic Riccati equation's predicted covariance, then one update."""
    F = np.kron(np.array([[1.0, DT], [0.0, 1.0]]), np.eye(2))  # x, y, vx, vy
    G = np.kron(np.array([[DT ** 2 / 2], [DT]]), np.eye(2))
    Q, H, R = p.acceleration_noise ** 2 * G @ G.T, np.eye(2, 4), p.position_noise ** 2 * np.eye(2)
    prior = solve_discrete_are(F.T, H.T, Q, R)
    return prior - prior @ H.T @ np.linalg.inv(H @ prior @ H.T + R) @ H @ prior


def test_a_target_at_constant_velocity_is_tracked_within_the_filters_steady_covariance():
    p = TrackerParams()
    tracker, rng, v = Tracker(p), np.random.default_rng(1), np.array([8.0, -3.0])
    errors = []
    for k in range(100):
        xy = np.array([-20.0, 10.0]) + v * k * DT + rng.normal(0.0, p.position_noise, 2)
        tracks = tracker.update(k * DT_NS, [box(*xy, math.atan2(v[1], v[0]))])
        if k * DT >= 3.0:  # converged: the gain's transient ~ a few times the filter's time constant (~0.5 s here)
            (t,) = tracks
            errors.append(np.hypot(t.vx - v[0], t.vy - v[1]))
    steady = steady_covariance(p)
    np.testing.assert_allclose(t.covariance, steady, rtol=1e-3, atol=1e-9)
    # the filter assumes random accelerations the target does not make, so it is conservative: the mean squared
    # error of the 2-D velocity is at most the trace of its velocity block
    assert math.sqrt(np.mean(np.square(errors))) <= 2 * math.sqrt(steady[2, 2] + steady[3, 3])
    assert t.yaw == pytest.approx(math.atan2(v[1], v[0]), abs=1e-12) and t.age == pytest.approx(9.9)


def test_scans_at_irregular_intervals_each_predict_over_their_own_interval():
    """Scans 0.1, 0.05, 0.1 and 0.25 s apart (the model of each interval made once and kept): the track's
    covariance is the Kalman filter's, each prediction over its own interval (Bar-Shalom et al. 2001, eq. 6.3.2-4)."""
    p = TrackerParams(confirm_hits=1)
    tracker, R = Tracker(p), p.position_noise ** 2 * np.eye(2)
    P = np.diag([p.position_noise ** 2] * 2 + [p.initial_speed ** 2] * 2)  # a new track's
    tracker.update(0, [box(10.0, 0.0)])
    stamps = [0, DT_NS, DT_NS + DT_NS // 2, 2 * DT_NS + DT_NS // 2, 5 * DT_NS]
    for before, now in pairwise(stamps):
        dt = (now - before) * 1e-9
        F = np.kron(np.array([[1.0, dt], [0.0, 1.0]]), np.eye(2))
        G = np.kron(np.array([[dt ** 2 / 2], [dt]]), np.eye(2))
        P = F @ P @ F.T + p.acceleration_noise ** 2 * G @ G.T
        K = P[:, :2] @ np.linalg.inv(P[:2, :2] + R)
        P = (np.eye(4) - K @ np.eye(2, 4)) @ P
        (t,) = tracker.update(now, [box(10.0, 0.0)])
        np.testing.assert_allclose(t.covariance, P, rtol=1e-9, atol=1e-12)


def test_two_crossing_targets_keep_their_ids():
    """Two cars cross on an X (through the same point at 2 s): the velocities carry each track through. A track's
    target is the one whose velocity it holds (their vy differ by 5 m/s), from 1 s on (converged)."""
    p = TrackerParams()
    tracker, rng = Tracker(p), np.random.default_rng(2)
    starts, v = np.array([[-20.0, -5.0], [-20.0, 5.0]]), np.array([[10.0, 2.5], [10.0, -2.5]])
    owner, spread = {}, 4 * math.sqrt(np.trace(steady_covariance(p)[:2, :2]))  # 4 standard deviations [m]
    for k in range(41):
        xy = starts + v * k * DT + rng.normal(0.0, p.position_noise, (2, 2))
        tracks = tracker.update(k * DT_NS, [box(*xy[0]), box(*xy[1])])
        for t in tracks if k >= 10 else ():
            target = int(np.argmin(np.hypot(*(v - [t.vx, t.vy]).T)))
            assert owner.setdefault(t.id, target) == target
            assert math.hypot(*(starts[target] + v[target] * k * DT - [t.x, t.y])) < spread  # and its position
    assert len(owner) == 2 and len(tracks) == 2


def test_a_track_is_reported_after_m_hits_of_n_scans_and_dropped_after_k_misses():
    p = TrackerParams(confirm_hits=3, confirm_scans=4, max_misses=3)
    tracker = Tracker(p)
    seen = [bool(tracker.update(k * DT_NS, [box(10.0, 0.0)])) for k in range(5)]
    assert seen == [False, False, True, True, True]  # the third hit confirms it
    seen = [bool(tracker.update((5 + k) * DT_NS, [])) for k in range(3)]
    assert seen == [True, True, False]  # coasting through two misses, gone at the third


def test_a_tentative_track_without_m_hits_in_its_first_n_scans_is_dropped():
    tracker = Tracker(TrackerParams(confirm_hits=3, confirm_scans=4, max_misses=3))
    pattern = [True, False, True, False, True, True, True]  # two hits in its first four scans
    out = [tracker.update(k * DT_NS, [box(10.0, 0.0)] if hit else []) for k, hit in enumerate(pattern)]
    assert not any(out[:5])  # dropped after scan 4; the box at scan 5 starts a new track, confirmed at scan 7
    (t,) = out[6]
    assert t.id == 2 and t.age == pytest.approx(2 * DT)


def test_a_box_seen_once_is_never_reported():
    tracker = Tracker()
    out = [tracker.update(k * DT_NS, [box(10.0, 0.0), *([box(-30.0, 4.0)] if k == 0 else [])]) for k in range(6)]
    assert {t.id for tracks in out for t in tracks} == {1}


def test_yaw_follows_the_velocity_and_the_size_turns_with_the_box():
    """A box moving towards -x reports yaw 0 (a box's yaw is known modulo pi); seen end on, its longer side is
    across the motion: the track's yaw is pi and its length the larger extent along the motion."""
    tracker = Tracker()
    for k in range(3):
        tracks = tracker.update(k * DT_NS, [box(30.0 - 10.0 * k * DT, 0.0)])
    tracks = tracker.update(3 * DT_NS, [box(27.0, 0.0, math.pi / 2, 1.8, 0.4)])  # only the rear face
    (t,) = tracks
    assert abs(t.yaw) == pytest.approx(math.pi, abs=0.1)
    assert (t.length, t.width) == (4.5, 1.8)  # the largest extents seen along and across


@pytest.mark.parametrize("bad", [[[1.0, 2.0, 0.0, 4.0]], [[1.0, math.nan, 0.0, 4.0, 2.0]], np.zeros((1, 1, 5))])
def test_boxes_not_finite_rows_of_five_are_refused_and_the_tracks_kept(bad):
    tracker = Tracker(TrackerParams(confirm_hits=1))
    tracker.update(0, [box(10.0, 0.0)])
    with pytest.raises(ValueError, match=r"boxes must be finite rows of x, y, yaw, length, width \(n, 5\)"):
        tracker.update(DT_NS, bad)
    assert [t.x for t in tracker.update(DT_NS, [box(10.0, 0.0)])] == [10.0]


def test_updates_out_of_time_order_are_refused():
    tracker = Tracker()
    tracker.update(DT_NS, [])
    with pytest.raises(ValueError, match="before the last one"):
        tracker.update(0, [])


@pytest.mark.parametrize(("field", "value"), [("acceleration_noise", 0.0), ("position_noise", -1.0),
                                              ("gate", math.nan), ("confirm_hits", 0), ("max_misses", 1.5),
                                              ("heading_speed", -1.0), ("confirm_hits", 5)])
def test_bad_params_are_refused(field, value):
    with pytest.raises(ValueError, match=field):
        TrackerParams(**{field: value})


def test_cars_driving_past_the_laser_are_tracked_from_its_scans():
    """Three cars at constant velocity ahead of a parked car (in its laser's view, none hiding another), scanned by
    vilma's planar laser (1081 rays, 10 Hz, 2 cm range noise), segmented, boxed and tracked: each is reported from
    its third scan on (M = 3) under one id and no phantom; a track's centre is the centre of the faces seen, within
    half the car's diagonal of the true centre."""
    size, n = (4.5, 1.8), 41
    starts = np.array([[5.0, 8.0, 0.0], [35.0, -6.0, math.pi], [10.0, 0.0, 0.0]])  # x, y, yaw
    speeds = np.array([8.0, 6.0, 5.0])
    v = speeds[:, None] * np.column_stack([np.cos(starts[:, 2]), np.sin(starts[:, 2])])
    t = np.arange(n) * DT
    poses = np.concatenate([starts[:, None, :2] + v[:, None] * t[:, None], np.repeat(starts[:, None, 2:], n, 1),
                            np.repeat(speeds[:, None, None], n, 1)], axis=-1)
    scene = boxes(poses, [size] * 3, dt=DT)
    laser = dataclasses.replace(SICK, range_noise=0.02)
    pose = laser_pose((0.0, 0.0, 0.0), (*laser.position[:2], laser.yaw))
    tracker, frames = Tracker(), []
    for k in range(n):
        ranges = scan(scene, stamp_ns=k * DT_NS, laser=laser)
        clusters = segment(ranges, laser.bearings, SegmentParams(range_noise=laser.range_noise))
        tracks = tracker.update(k * DT_NS, fit_boxes(scan_points(ranges, laser.bearings), clusters, pose))
        frames.append(MotFrame(scene.ids, poses[:, k, :2], v, np.array([t.id for t in tracks], np.int64),
                               np.array([[t.x, t.y] for t in tracks]).reshape(-1, 2),
                               np.array([[t.vx, t.vy] for t in tracks]).reshape(-1, 2)))
    half_diagonal = math.hypot(*size) / 2
    s = clear_mot(frames, threshold=2 * half_diagonal)
    assert (s.misses, s.false_positives, s.id_switches) == (2 * 3, 0, 0)
    assert s.motp <= half_diagonal


def test_a_lone_box_outside_the_lone_tracks_gate_starts_a_track_of_its_own():
    """A box 20 m from the only track (standing still, its position known within a metre: a squared Mahalanobis
    distance in the hundreds, far past the gate) updates nothing: the track coasts, a new one is born at the box."""
    tracker = Tracker(TrackerParams(confirm_hits=2, confirm_scans=3, max_misses=3))
    (before,) = [tracker.update(k * DT_NS, [box(10.0, 0.0)]) for k in range(2)][1]
    (coasting,) = tracker.update(2 * DT_NS, [box(30.0, 0.0)])
    assert (coasting.id, coasting.x, coasting.y) == (1, 10.0, 0.0)  # at rest: predicted where it was
    assert np.trace(coasting.covariance) > np.trace(before.covariance)  # predicted only, not updated
    (old, new) = tracker.update(3 * DT_NS, [box(30.0, 0.0)])
    assert (old.id, old.x, new.id, new.x, new.age) == (1, 10.0, 2, 30.0, DT)


def test_scans_with_nothing_seen_and_nothing_tracked_still_keep_the_time_order():
    tracker = Tracker(TrackerParams(confirm_hits=1))
    assert tracker.update(5 * DT_NS, []) == [] and tracker.update(6 * DT_NS, np.zeros((0, 5))) == []
    with pytest.raises(ValueError, match="before the last one at 600000000 ns"):
        tracker.update(5 * DT_NS, [])
    (t,) = tracker.update(7 * DT_NS, [box(10.0, 0.0)])
    assert (t.id, t.x, t.age) == (1, 10.0, 0.0)
