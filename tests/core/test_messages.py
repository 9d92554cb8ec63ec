import math

import msgspec
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.core.messages import ActuatorCommand, GpsFix, LocalPlan, Longitudinal, PlannedPath, Pose, Velocity


def test_messages_round_trip_through_msgpack():
    msgs = [Pose(5, 1.0, 2.0, 0.0, 0.0, 0.0, 0.3), GpsFix(7, -22.8, -47.0, 600.0, 1.0, 2.0, 3.0),
            ActuatorCommand(steer=0.2, longitudinal=Longitudinal.POWER, drive=500.0, velocity_limit=100.0)]
    for m in msgs:
        assert msgspec.msgpack.decode(msgspec.msgpack.encode(m), type=type(m)) == m


def test_tagged_union_decodes_the_right_type():
    m = Pose(1, 1.0, 2.0, 0.0, 0.0, 0.0, 0.1)
    assert type(msgspec.msgpack.decode(msgspec.msgpack.encode(m), type=Pose | GpsFix)) is Pose


def test_derived_values():
    assert Velocity(0, 3.0, 4.0, 0, 0, 0, 0, 0, 0, 0).speed == 5.0
    q = Pose(0, 0, 0, 0, 0, 0, math.pi / 2).quaternion
    assert q == pytest.approx((0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)))


def test_command_defaults_are_a_safe_idle():
    c = ActuatorCommand()
    assert (c.steer, c.drive, c.brake, c.autonomous) == (0.0, 0.0, 0.0, False)
    assert c.longitudinal is Longitudinal.FORCE and c.velocity_limit == math.inf


def _plan_frame(x: int, y: int, speed: int, path_x: int, path_y: int) -> bytes:
    """A LocalPlan of ``x``, ``y`` and ``speed`` values, with one candidate of ``path_x`` and ``path_y`` values,
    encoded as a peer may (without the checks of building one)."""
    path = {"id": -1, "status": 0, "x": [1.0] * path_x, "y": [2.0] * path_y}
    return msgspec.msgpack.encode(["LocalPlan", 1, "follow", "", 0.1, [1.0] * x, [2.0] * y, [3.0] * speed, [path], [],
                                   math.nan])


@given(*[st.integers(0, 4)] * 5)
def test_a_plan_decodes_only_when_each_path_pairs_its_xs_and_ys(x, y, speed, path_x, path_y):
    frame = _plan_frame(x, y, speed, path_x, path_y)
    if x == y == speed and path_x == path_y:
        plan = msgspec.msgpack.decode(frame, type=LocalPlan)
        assert len(plan.speed) == speed and len(plan.candidates[0].y) == path_y
    else:
        with pytest.raises(msgspec.ValidationError, match="give as many of each"):
            msgspec.msgpack.decode(frame, type=LocalPlan)


def test_a_plan_or_path_whose_columns_differ_is_not_made():
    with pytest.raises(ValueError, match=r"^a trajectory of 3 x, 1 y, 3 speed: give as many of each$"):
        LocalPlan(1, "follow", "", 0.1, [1.0, 2.0, 3.0], [1.0], [1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match=r"^a path of 3 x, 1 y: give as many of each$"):
        PlannedPath(-1, 0, [1.0, 2.0, 3.0], [1.0])
