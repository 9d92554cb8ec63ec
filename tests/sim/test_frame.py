"""The compiled frame: its plant constants cross as an array and come back whole; it is called directly."""

import dataclasses

import numpy as np
from numba import njit

from vilma.sim.frame import direct
from vilma.vehicle.actuators import consts_of
from vilma.vehicle.params import plant_consts, vilma


def test_the_plant_constants_come_back_from_their_array_field_by_field():
    consts = plant_consts(dataclasses.replace(vilma(), mass=1234.5, friction=0.7))
    assert consts_of(np.array(consts)) == consts


@njit(cache=True)
def _scaled(a, k):
    return a * k


def test_a_direct_call_runs_the_overload_for_its_arguments_types():
    call = direct(_scaled, 2, 0.5)
    assert call(3, 1.5) == 4.5
    assert call(np.int64(3), 2) == 6.0  # arguments convert to the types it was made for
    assert direct(_scaled, 2, 0.5) is call
