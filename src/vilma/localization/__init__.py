"""Localization: the pose the controllers steer by, from a selectable source (exact pose or an EKF)."""

from vilma.localization.base import PoseEstimator
from vilma.localization.ekf import Ekf, EkfParams
from vilma.localization.factory import SOURCES, make_estimator
from vilma.localization.truth import TruthEstimator

__all__ = ["SOURCES", "Ekf", "EkfParams", "PoseEstimator", "TruthEstimator", "make_estimator"]
