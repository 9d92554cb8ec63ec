"""Controller parameters refuse what would make the driver divide by zero, search nothing or go NaN."""

from __future__ import annotations

import math

import pytest

from vilma.control.path.pure_pursuit import PurePursuitParams
from vilma.control.path.stanley import StanleyParams
from vilma.control.path.vilma_heading import VilmaHeadingParams
from vilma.control.speed.pi_ff import PiFfParams
from vilma.control.speed.vilma_pid import VilmaPidParams


@pytest.mark.parametrize(("make", "message"), [
    (lambda: StanleyParams(period=0.0), "stanley period must be a finite number > 0, got 0.0"),
    (lambda: StanleyParams(softening=0.0), "stanley softening must be a finite number > 0"),
    (lambda: StanleyParams(window=0), "stanley window must be at least 1 segment, got 0"),
    (lambda: StanleyParams(gain=-1.0), "stanley gain must be a finite number >= 0, got -1.0"),
    (lambda: PurePursuitParams(lookahead_min=5.0, lookahead_max=2.0), "lookahead_max 2.0 must be >= lookahead_min"),
    (lambda: PiFfParams(kp=math.nan), "pi_ff kp must be a finite number >= 0, got nan"),
    (lambda: PiFfParams(max_jerk=0.0), "pi_ff max_jerk must be a finite number > 0"),
    (lambda: VilmaPidParams(ki=math.inf), "vilma_pid ki must be a finite number >= 0, got inf"),
    (lambda: VilmaHeadingParams(max_steer=0.0), "vilma_heading max_steer must be a finite number > 0"),
])
def test_out_of_range_parameters_are_refused_by_name(make, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        make()


def test_the_defaults_and_the_original_pass():
    """(Made without an error: each constructor runs the check.)"""
    StanleyParams(point="front_axle"), PurePursuitParams(), PiFfParams(), VilmaPidParams.original()
    VilmaHeadingParams(original_quirks=True)
