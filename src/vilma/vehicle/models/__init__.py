"""Planar vehicle models as pure functions ``f(x, u, p) -> dx``.

``x`` is the vehicle state (see :mod:`vilma.vehicle.state`), ``u`` the
actuator outputs ``(steer [rad], drive force [N], brake force [N])`` as held
over a step (:func:`held`: with the steering's trigonometry) and ``p`` a
:class:`~vilma.vehicle.params.PlantConsts`. All are compiled with numba.
"""

from vilma.vehicle.models.common import held
from vilma.vehicle.models.kinematic import kinematic, kinematic_constrain
from vilma.vehicle.models.single_track import single_track, single_track_constrain

MODELS = ("kinematic", "single_track")
"""Model names, indexed by model id."""

__all__ = ["MODELS", "held", "kinematic", "kinematic_constrain", "single_track", "single_track_constrain"]
