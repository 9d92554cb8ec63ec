"""L-shape boxes against geometry: a box seen by vilma's planar laser is fitted within what the ray spacing and
the orientation search step allow."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.perception.conftest import SICK, boxes, scan
from vilma.core.geometry import wrap_angle
from vilma.perception.boxes import BOX_LENGTH, BOX_WIDTH, BOX_X, BOX_Y, BOX_YAW, BoxParams, fit_boxes, laser_pose
from vilma.perception.segment import SegmentParams, scan_points, segment
from vilma.vehicle.state import VehicleState

CAR = VehicleState(x=5.0, y=-3.0, yaw=0.4)
MOUNT = (*SICK.position[:2], SICK.yaw)
STEP = BoxParams().angle_step
DPHI = math.radians(SICK.resolution)


def seen(centre_in_laser, relative_yaw: float, size) -> tuple[np.ndarray, np.ndarray]:
    """The fitted boxes (n, 5) of one scan of a box at ``centre_in_laser`` (x, y) [m] in the laser frame, turned by
    ``relative_yaw`` [rad] from the ray through its centre, and that box's x, y, yaw in the world frame."""
    lx, ly, lyaw = laser_pose((CAR.x, CAR.y, CAR.yaw), MOUNT)
    bearing = math.atan2(centre_in_laser[1], centre_in_laser[0])
    c, s = math.cos(lyaw), math.sin(lyaw)
    truth = np.array([lx + c * centre_in_laser[0] - s * centre_in_laser[1],
                      ly + s * centre_in_laser[0] + c * centre_in_laser[1], lyaw + bearing + relative_yaw])
    ranges = scan(boxes([[truth]], [size]), CAR)
    clusters = segment(ranges, SICK.bearings, SegmentParams(range_noise=0.0))
    return fit_boxes(scan_points(ranges, SICK.bearings), clusters, (lx, ly, lyaw)), truth


def test_laser_pose_is_the_mount_carried_by_the_car():
    assert laser_pose((1.0, 2.0, math.pi / 2), (1.9, 0.5, 0.1)) == pytest.approx((0.5, 3.9, math.pi / 2 + 0.1))


@pytest.mark.parametrize("relative_yaw", np.radians([35.0, 45.0, 55.0, 125.0, -45.0, 137.3]))
@pytest.mark.parametrize("size", [(4.5, 1.8), (12.0, 2.5)])
def test_a_box_seen_on_two_faces_is_fitted_within_the_ray_spacing_and_the_search_step(relative_yaw, size):
    """Both faces meet the rays at 30 deg or more (the box turned 30 .. 60 deg from the ray to its centre, modulo
    90): neighbouring hits on a face are at most r sin(dphi) / sin(30 deg - dphi) apart (law of sines), so each
    face's points reach within one such gap of its ends; turning the edges by up to the search step moves the
    extreme points' projections by at most the diagonal times that step."""
    d = 15.0
    (box,), truth = seen((d * math.cos(0.3), d * math.sin(0.3)), relative_yaw, size)
    diag = math.hypot(*size)
    gap = (d + diag / 2) * math.sin(DPHI) / math.sin(math.radians(30.0) - DPHI)
    tol = 2 * gap + 2 * diag * math.sin(STEP)
    assert abs(wrap_angle(2 * (box[BOX_YAW] - truth[2]))) / 2 <= STEP  # a box's yaw is known modulo pi
    assert box[BOX_LENGTH] == pytest.approx(size[0], abs=tol) and box[BOX_WIDTH] == pytest.approx(size[1], abs=tol)
    assert math.hypot(box[BOX_X] - truth[0], box[BOX_Y] - truth[1]) <= tol


def test_a_box_seen_on_one_face_is_that_face():
    """Broadside straight ahead, only the near face is seen: the box is that face, as wide as the face looks turned
    by the search step at most, its length within a ray spacing at each end (the face 2.25 m either side of the
    ray at 15 m: gaps r dphi / cos^2(b) at most) and that turn."""
    length, width, d = 4.5, 1.8, 15.0
    (box,), truth = seen((d, 0.0), math.pi / 2, (length, width))
    gap = d * DPHI / math.cos(math.atan(length / 2 / d)) ** 2
    turn = length * math.sin(STEP)
    assert box[BOX_WIDTH] <= turn
    assert box[BOX_LENGTH] == pytest.approx(length, abs=2 * gap + turn)
    face = truth[:2] - (width / 2) * np.array([math.cos(truth[2] - math.pi / 2), math.sin(truth[2] - math.pi / 2)])
    assert math.hypot(box[BOX_X] - face[0], box[BOX_Y] - face[1]) <= gap + turn


def test_boxes_keep_length_over_width_and_yaw_within_a_half_turn():
    got = np.concatenate([seen((15.0, 0.0), a, (4.5, 1.8))[0] for a in np.linspace(-3.0, 3.0, 13)])
    assert (got[:, BOX_LENGTH] >= got[:, BOX_WIDTH]).all()
    assert ((got[:, BOX_YAW] > -math.pi / 2) & (got[:, BOX_YAW] <= math.pi / 2)).all()


def test_no_cluster_gives_no_box():
    assert fit_boxes(np.zeros((5, 2)), [], (0.0, 0.0, 0.0)).shape == (0, 5)


@pytest.mark.parametrize("clusters", [[np.array([0, 1]), np.zeros(0, np.int64)], [np.array([1, 2])]])
def test_an_empty_cluster_or_one_without_returns_is_refused(clusters):
    points = np.array([[1.0, 0.0], [1.0, 0.1], [np.nan, np.nan]])
    with pytest.raises(ValueError, match="give the clusters of segment"):
        fit_boxes(points, clusters, (0.0, 0.0, 0.0))


@pytest.mark.parametrize(("field", "value"), [("angle_step", 0.0), ("angle_step", 2.0), ("min_distance", 0.0),
                                              ("min_distance", math.inf)])
def test_bad_params_are_refused(field, value):
    with pytest.raises(ValueError, match=field):
        BoxParams(**{field: value})
