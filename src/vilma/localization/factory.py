"""The pose estimator for a named source."""

from __future__ import annotations

from vilma.localization.base import PoseEstimator
from vilma.localization.ekf import Ekf, EkfParams
from vilma.localization.truth import TruthEstimator
from vilma.vehicle.params import VehicleParams

SOURCES = ("truth", "ekf")
"""The pose sources :func:`make_estimator` knows."""


def make_estimator(source: str, vehicle: VehicleParams, ekf: EkfParams | None = None) -> PoseEstimator:
    """The estimator for ``source``: ``truth`` (the exact pose) or ``ekf`` (with ``ekf``, default for ``vehicle``)."""
    if source == "truth":
        return TruthEstimator()
    if source == "ekf":
        return Ekf(ekf or EkfParams.for_vehicle(vehicle))
    raise ValueError(f"unknown pose source {source!r}; use one of {', '.join(SOURCES)}")
