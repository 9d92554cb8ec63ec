"""Planar vehicle models as pure functions ``f(x, u, p) -> dx``.

``x`` is the vehicle state (see :mod:`vilma.vehicle.state`), ``u`` the
actuator outputs ``(steer [rad], drive force [N], brake force [N])`` as held
over a step (:func:`held`: with the steering's trigonometry) and ``p`` a
:class:`~vilma.vehicle.params.PlantConsts`. All are compiled with numba, with numpy's error model: no divisor in
them can be zero (the parameters are checked positive), and numba's check of each division for zero cost a tenth
of a derivative.
"""

from vilma.vehicle.models.common import held
from vilma.vehicle.models.kinematic import kinematic, kinematic_constrain
from vilma.vehicle.models.single_track import single_track, single_track_constrain

MODELS = ("kinematic", "single_track")
"""Model names, indexed by model id."""

__all__ = ["MODELS", "held", "kinematic", "kinematic_constrain", "single_track", "single_track_constrain"]
