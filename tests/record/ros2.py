"""ROS 2 messages decoded as Foxglove's own Python package (``mcap_ros2``) decodes them: an independent reader."""

from __future__ import annotations

import itertools
from collections.abc import Callable

from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

_ids = itertools.count(1)


def ros2_decoder(schema_name: str, schema: bytes | str) -> Callable[[bytes], object]:
    """The decoder of CDR payloads of ``schema_name`` whose ``ros2msg`` text is ``schema``."""
    data = schema.encode() if isinstance(schema, str) else schema
    return DecoderFactory().decoder_for("cdr", Schema(id=next(_ids), name=schema_name, encoding="ros2msg", data=data))
