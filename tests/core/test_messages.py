import math

import msgspec
import pytest

from vilma.core.messages import ActuatorCommand, GpsFix, Longitudinal, Pose, Velocity


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
