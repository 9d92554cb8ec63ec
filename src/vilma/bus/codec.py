"""Messages on the wire: msgpack (msgspec) with a schema version, decoded strictly.

A frame is the msgpack array ``[SCHEMA_VERSION, message]`` where the message
is the tagged msgspec struct (its type name as tag). Decoding checks the
version, the shape and the type the topic carries; anything else is
:class:`DecodeError`, which the buses log and drop.
"""

from __future__ import annotations

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


class DecodeError(ValueError):
    """A frame that is not a message of this schema: wrong version, shape or type."""


def encode(msg: Message) -> bytes:
    """The frame of ``msg``."""
    return _encoder.encode((SCHEMA_VERSION, msg))


def decode(frame: bytes, expected: type[Message] | None = None) -> Message:
    """The message in ``frame``; it must be of type ``expected`` when given.

    Raises:
        DecodeError: another schema version, a malformed frame, or another message type.
    """
    try:
        version, _ = _version.decode(frame)
    except (msgspec.DecodeError, msgspec.ValidationError) as e:
        raise DecodeError(f"not a vilma frame: {e}") from None
    if version != SCHEMA_VERSION:
        raise DecodeError(f"schema version {version}, this vilma speaks {SCHEMA_VERSION}: update the sender or vilma")
    try:
        _, msg = _decoder.decode(frame)
    except (msgspec.DecodeError, msgspec.ValidationError) as e:
        raise DecodeError(f"malformed message: {e}") from None
    if expected is not None and not isinstance(msg, expected):
        raise DecodeError(f"a {type(msg).__name__} where a {expected.__name__} belongs")
    return msg
