"""Frames on the wire: round trips, versions, and garbage that never crashes a decoder."""

from __future__ import annotations

import contextlib
import math
import typing

import msgspec
import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.bus.codec import MAX_FRAME_BYTES, MAX_WORLD_FRAME_BYTES, SCHEMA_VERSION, DecodeError, decode, encode
from vilma.bus.topics import TOPICS, message_type, topic
from vilma.core.messages import (
    MAX_FILE_NAME_CHARS,
    MAX_GAINS,
    MAX_NAME_CHARS,
    MAX_ORDER_POINTS,
    MAX_PATH_POINTS,
    MAX_PLAN_PATHS,
    MAX_REASON_CHARS,
    ActuatorCommand,
    DriverOrder,
    GpsFix,
    Image,
    LocalPlan,
    Longitudinal,
    PlannedPath,
    Pose,
    Reply,
)


@pytest.mark.parametrize("msg", [
    Pose(5, 1.0, -2.0, 0.0, 0.0, 0.0, 3.0),
    ActuatorCommand(stamp_ns=7, steer=-0.2, longitudinal=Longitudinal.POWER, drive=500.0, velocity_limit=math.inf),
    DriverOrder(action="follow", points=[(0.0, 0.0), (10.0, 5.0)], speed=4.0),
    Reply(ok=False, error="why"),
])
def test_round_trip(msg):
    back = decode(encode(msg), type(msg))
    assert encode(back) == encode(msg)  # (NaN fields make == useless)
    assert type(back) is type(msg)


def test_every_topic_type_round_trips():
    for name, cls in TOPICS.items():
        fields = {f.name: f.default for f in msgspec.structs.fields(cls) if f.default is not msgspec.NODEFAULT}
        required = [f for f in msgspec.structs.fields(cls) if f.default is msgspec.NODEFAULT
                    and f.default_factory is msgspec.NODEFAULT]
        bare = [getattr(f.type, "__origin__", f.type) for f in required]  # (a capped str is Annotated[str, ...])
        scalars = {int: 1, float: 1.5, str: "x", bool: True}
        sample = {f.name: [1.5] if typing.get_origin(b) is list else scalars.get(b, 1)
                  for f, b in zip(required, bare, strict=True)}
        msg = cls(**{**fields, **sample})
        assert encode(decode(encode(msg), message_type(topic(name)))) == encode(msg)


def test_wrong_version_shape_or_type_is_a_decode_error():
    with pytest.raises(DecodeError, match=f"schema version 99, this vilma speaks {SCHEMA_VERSION}"):
        decode(msgspec.msgpack.encode((99, Pose(0, 0, 0, 0, 0, 0, 0))))
    with pytest.raises(DecodeError, match="a Pose where a GpsFix belongs"):
        decode(encode(Pose(0, 0, 0, 0, 0, 0, 0)), GpsFix)
    with pytest.raises(DecodeError, match="malformed message"):
        decode(msgspec.msgpack.encode((SCHEMA_VERSION, ["Pose", "late", 1.0])))
    with pytest.raises(DecodeError, match="not a vilma frame"):
        decode(b"\x00garbage")


def test_a_frame_over_its_limit_is_refused_unread():
    garbage = b"\xc1" * (MAX_FRAME_BYTES + 1)  # (0xc1 is never msgpack: a frame read would fail otherwise)
    with pytest.raises(DecodeError, match=f"a frame of {MAX_FRAME_BYTES + 1} bytes, over the 4 MiB limit of "
                                          "DriverOrder; send less in one message"):
        decode(garbage, DriverOrder)
    with pytest.raises(DecodeError, match="not a vilma frame"):  # an image may be larger
        decode(garbage, Image)
    with pytest.raises(DecodeError, match="over the 64 MiB limit of Image"):
        decode(garbage + bytes(MAX_WORLD_FRAME_BYTES - MAX_FRAME_BYTES), Image)


def _word(i: int) -> str:
    """A name at the cap in the widest UTF-8 (4 bytes a character), different for each ``i``."""
    return chr(0x10000 + i) * MAX_NAME_CHARS


def test_the_largest_order_fits_a_frame_and_one_more_point_or_name_is_refused():
    largest = DriverOrder(
        action=_word(0), points=[(1e300, -1e300)] * MAX_ORDER_POINTS, speeds=[1e300] * MAX_ORDER_POINTS,
        file=chr(0x10000) * MAX_FILE_NAME_CHARS, speed_controller=_word(1), path_controller=_word(2),
        gains={_word(i): {_word(j): _word(j) for j in range(MAX_GAINS)} for i in range(MAX_GAINS)})
    frame = encode(largest)
    assert len(frame) <= MAX_FRAME_BYTES and decode(frame, DriverOrder).points == largest.points
    for field, value in (("points", [(0.0, 0.0)] * (MAX_ORDER_POINTS + 1)), ("speeds", [1.0] * (MAX_ORDER_POINTS + 1)),
                         ("file", "a" * (MAX_FILE_NAME_CHARS + 1)), ("action", "a" * (MAX_NAME_CHARS + 1)),
                         ("gains", {str(i): {} for i in range(MAX_GAINS + 1)})):
        with pytest.raises(DecodeError, match=f"of length <= .* - at `{field}`$"):
            decode(encode(msgspec.structs.replace(largest, **{field: value})), DriverOrder)


def test_the_largest_plan_fits_a_frame_and_one_more_path_point_or_character_is_refused():
    full = [1e300] * MAX_PATH_POINTS
    path = PlannedPath(-(2**63), -(2**63), full, full)
    largest = LocalPlan(-(2**63), _word(0), chr(0x10000) * MAX_REASON_CHARS, 1e300, full, full, full,
                        [path] * MAX_PLAN_PATHS, [path] * MAX_PLAN_PATHS, 1e300)
    frame = encode(largest)
    assert len(frame) <= MAX_FRAME_BYTES and decode(frame, LocalPlan).candidates == largest.candidates
    longer = PlannedPath(-1, 0, [*full, 0.0], [*full, 0.0])
    for field, value in (("candidates", [path] * (MAX_PLAN_PATHS + 1)), ("predictions", [longer]),
                         ("mode", "a" * (MAX_NAME_CHARS + 1)), ("reason", "a" * (MAX_REASON_CHARS + 1))):
        with pytest.raises(DecodeError, match=f"of length <= .* - at `{field}"):
            decode(encode(msgspec.structs.replace(largest, **{field: value})), LocalPlan)
    with pytest.raises(DecodeError, match=r"of length <= .* - at `x`$"):
        decode(encode(msgspec.structs.replace(largest, x=[*full, 0.0], y=[*full, 0.0], speed=[*full, 0.0])),
               LocalPlan)


@given(st.binary(max_size=200))
def test_random_bytes_decode_or_fail_cleanly(frame):
    with contextlib.suppress(DecodeError):
        decode(frame)


FRAME_START = b"\x92" + msgspec.msgpack.encode(SCHEMA_VERSION)
"""A frame's two-item array and its schema version."""


@given(st.integers(1, 100_000), st.sampled_from([b"\x91", b"\x81\xa1k", b"\xdc\x00\x01"]))
def test_a_frame_nested_at_any_depth_is_a_decode_error(depth, container):
    """A peer may nest arrays or maps far past Python's recursion limit (msgspec's RecursionError there)."""
    with pytest.raises(DecodeError):
        decode(FRAME_START + container * depth + b"\x00")


def test_topic_names():
    assert topic("driver/status", "car2") == "vilma/car2/driver/status"
    assert message_type("vilma/car2/gps") is GpsFix
    with pytest.raises(ValueError, match="unknown topic 'lidar'"):
        topic("lidar")
    with pytest.raises(ValueError, match="car name 'a/b'"):
        topic("pose", "a/b")
    with pytest.raises(ValueError, match="not a vilma topic"):
        message_type("ros/pose")


def test_a_plan_whose_xs_and_ys_differ_is_refused_naming_the_path():
    frame = msgspec.msgpack.encode((SCHEMA_VERSION, ["LocalPlan", 1, "follow", "", 0.1, [0.0, 1.0], [0.0, 1.0],
                                                     [2.0, 2.0], [{"id": -1, "status": 0, "x": [0.0], "y": []}]]))
    with pytest.raises(DecodeError, match=r"^malformed message: a path of 1 x, 0 y: give as many of each - at "
                                          r"`candidates\[0\]`$"):
        decode(frame, LocalPlan)
