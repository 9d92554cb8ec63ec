"""Network addresses: which ones stay on this machine, and Zenoh's endpoints."""

from __future__ import annotations

import ipaddress
import re


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an IP address, ``[v6]`` or ``localhost``) is on the loopback interface only."""
    host = host.strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


ENDPOINT_EXAMPLE = "tcp/127.0.0.1:7447"
IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
"""Zenoh's protocols whose address is ``<host>:<port>``."""
OTHER_PROTOCOLS = ("unixsock-stream", "unixpipe", "serial", "vsock")
"""Zenoh's protocols whose address is a path, a device or a vsock address."""
_HOST = re.compile(r"[A-Za-z0-9]([A-Za-z0-9.-]*[A-Za-z0-9])?")
"""A host name or an IPv4 address."""


def check_endpoint(endpoint: str, listen: bool) -> None:
    """Raises ValueError unless ``endpoint`` is a Zenoh endpoint, ``<protocol>/<address>[?<metadata>][#<config>]``,
    whose address, for an IP protocol, is ``<host>:<port>`` with a port 1-65535 (0 too, to ``listen`` on any free
    one). The message does not quote the endpoint (it may come from a file that is not one)."""
    protocol, _, rest = endpoint.partition("/")
    address = re.split(r"[?#]", rest, maxsplit=1)[0]
    if not protocol or not address:
        raise ValueError(f"not an endpoint: give <protocol>/<address>, e.g. {ENDPOINT_EXAMPLE}")
    if protocol in OTHER_PROTOCOLS:
        return
    if protocol not in IP_PROTOCOLS:
        raise ValueError(f"unknown protocol: use one of {', '.join(IP_PROTOCOLS + OTHER_PROTOCOLS)}")
    host, colon, port = address.rpartition(":")
    if not colon:
        raise ValueError(f"no port: give <host>:<port> after the protocol, e.g. {ENDPOINT_EXAMPLE}")
    if not (port.isascii() and port.isdigit() and (0 if listen else 1) <= int(port) <= 65535):
        raise ValueError(f"the port must be a whole number 1-65535{' (0: any free port)' if listen else ''}")
    if not _is_host(host):
        raise ValueError("the host must be a name, an IPv4 address or an [IPv6] address")


def _is_host(host: str) -> bool:
    if host.startswith("[") and host.endswith("]"):
        try:
            return ipaddress.ip_address(host[1:-1]).version == 6
        except ValueError:
            return False
    if not _HOST.fullmatch(host):
        return False
    if host.replace(".", "").isdigit():  # (digits and dots: an IPv4 address, else a name)
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            return False
    return True
