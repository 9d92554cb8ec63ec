"""Messages on the wire: msgpack (msgspec) with a schema version, decoded strictly.

A frame is the msgpack array ``[SCHEMA_VERSION, message]`` where the message
is the tagged msgspec struct (its type name as tag). Decoding checks the
version, the size, the nesting, the shape and the type the topic carries; anything else is
:class:`DecodeError`, which the buses log and drop (or answer, for a request).
"""

from __future__ import annotations

import re
from typing import Union

import msgspec

from vilma.bus.topics import TOPICS, WORLD_TOPICS
from vilma.core.messages import Message, Reply

SCHEMA_VERSION = 2
"""Bumped whenever a message's fields change."""

AnyMessage = Union[tuple(dict.fromkeys([*TOPICS.values(), *WORLD_TOPICS.values(), Reply]))]  # noqa: UP007 (a union built at run time)

_encoder = msgspec.msgpack.Encoder()
_decoder = msgspec.msgpack.Decoder(tuple[int, AnyMessage])
_version = msgspec.msgpack.Decoder(tuple[int, msgspec.Raw])
_FIELD = re.compile(r"`\$\[1\]\[(\d+)\]")
"""Where msgspec places an error: field i of the (array-like) message, after its tag."""


class _Tag(msgspec.Struct, array_like=True):
    """A message's tag (its type's name); the fields after it are skipped."""

    name: str


_tag = msgspec.msgpack.Decoder(tuple[int, _Tag])
_types = {t.__name__: t for t in AnyMessage.__args__}

MAX_FRAME_BYTES = 4 * 2**20
"""The largest frame of a command, an order, a plan, a reply, a status or a reading [bytes]: room for the largest
order (3.4 MB: ``MAX_ORDER_POINTS`` points and speeds at 28 bytes each, and every name at its cap) and the largest
plan (3.7 MB: ``MAX_PLAN_PATHS`` candidates and predictions of ``MAX_PATH_POINTS`` points at 18 bytes each)."""
MAX_WORLD_FRAME_BYTES = 64 * 2**20
"""The largest frame of a camera image or a laser scan [bytes] (a 3840 x 2160 depth image takes 33 MB)."""


class DecodeError(ValueError):
    """A frame that is not a message of this schema: too large, wrong version, shape or type."""


def encode(msg: Message) -> bytes:
    """The frame of ``msg``."""
    return _encoder.encode((SCHEMA_VERSION, msg))


def decode(frame: bytes, expected: type[Message] | None = None) -> Message:
    """The message in ``frame``; it must be of type ``expected`` when given. A frame over the size limit of its
    type (:data:`MAX_FRAME_BYTES`, :data:`MAX_WORLD_FRAME_BYTES`; the larger when no type is expected) is refused
    unread.

    Raises:
        DecodeError: too large, another schema version, a malformed frame (nested too deep too), or another message
            type.
    """
    limit = MAX_FRAME_BYTES if expected is not None and expected not in WORLD_TOPICS.values() else \
        MAX_WORLD_FRAME_BYTES
    if len(frame) > limit:
        raise DecodeError(f"a frame of {len(frame)} bytes, over the {limit >> 20} MiB limit of "
                          f"{expected.__name__ if expected else 'a message'}; send less in one message")
    try:
        version, _ = _version.decode(frame)
    except (msgspec.DecodeError, msgspec.ValidationError, RecursionError) as e:  # (nested past Python's limit)
        raise DecodeError(f"not a vilma frame: {e}") from None
    if version != SCHEMA_VERSION:
        raise DecodeError(f"schema version {version}, this vilma speaks {SCHEMA_VERSION}: update the sender or vilma")
    try:
        _, msg = _decoder.decode(frame)
    except (msgspec.DecodeError, msgspec.ValidationError) as e:
        raise DecodeError(f"malformed message: {_named(str(e), frame)}") from None
    if expected is not None and not isinstance(msg, expected):
        raise DecodeError(f"a {type(msg).__name__} where a {expected.__name__} belongs")
    return msg


def _named(error: str, frame: bytes) -> str:
    """msgspec's ``error`` about ``frame`` with the field it names by position named as in the frame's type."""
    try:
        kind = _types.get(_tag.decode(frame)[1].name)
    except (msgspec.DecodeError, msgspec.ValidationError):
        kind = None
    fields = kind.__struct_fields__ if kind is not None else ()
    error = error.removesuffix(" - at `$[1]`")  # (the message itself: its own check failed)
    return _FIELD.sub(lambda m: "`" + fields[int(m[1]) - 1] if 0 < int(m[1]) <= len(fields) else m[0], error)
