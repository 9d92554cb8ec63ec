"""The compiled frame: its plant constants cross as an array and come back whole."""

import dataclasses

import numpy as np

from vilma.vehicle.actuators import consts_of
from vilma.vehicle.params import plant_consts, vilma


def test_the_plant_constants_come_back_from_their_array_field_by_field():
    consts = plant_consts(dataclasses.replace(vilma(), mass=1234.5, friction=0.7))
    assert consts_of(np.array(consts)) == consts
