"""The bus between vilma's parts: in-process (:class:`LocalBus`) or across processes and hosts (Zenoh)."""

from vilma.bus.base import BoundedQueue, Bus, Latest
from vilma.bus.codec import SCHEMA_VERSION, DecodeError, decode, encode
from vilma.bus.local import LocalBus
from vilma.bus.topics import SENSOR_TOPICS, TOPICS, topic

__all__ = ["SCHEMA_VERSION", "SENSOR_TOPICS", "TOPICS", "BoundedQueue", "Bus", "DecodeError", "Latest", "LocalBus",
           "decode", "encode", "topic"]
