"""Which peers' commands a MORSE interface takes (``allow_commands_from``)."""

from __future__ import annotations

import ipaddress
from collections.abc import Collection

Network = ipaddress.IPv4Network | ipaddress.IPv6Network


def parse_networks(allow: Collection[str] | None) -> tuple[Network, ...] | None:
    """``allow_commands_from`` as networks (an address is a /32 or /128); ValueError on a bad entry."""
    if allow is None:
        return None
    if isinstance(allow, str):
        allow = (allow,)
    nets = []
    for a in allow:
        try:
            nets.append(ipaddress.ip_network(a, strict=False))
        except ValueError:
            raise ValueError(f"allow_commands_from: {a!r} is not an IP address or network; "
                             f"use e.g. '127.0.0.1' or '192.168.1.0/24'") from None
    return tuple(nets)


class CommandAccess:
    """The peers whose commands are taken: addresses or networks (None: everyone); ValueError on a bad entry."""

    def __init__(self, allow_commands_from: Collection[str] | None = None) -> None:
        self._allow = parse_networks(allow_commands_from)

    def allowed(self, address: str) -> bool:
        """Whether commands from peer ``address`` are taken."""
        if self._allow is None:
            return True
        try:
            ip = ipaddress.ip_address(address.split("%", 1)[0])
        except ValueError:
            return False
        if isinstance(ip, ipaddress.IPv6Address) and ip.ipv4_mapped is not None:
            ip = ip.ipv4_mapped
        return any(ip.version == n.version and ip in n for n in self._allow)

    def refusal(self, address: str) -> str:
        """The one-line error for a command from a peer outside ``allow_commands_from``."""
        allowed = ", ".join(str(n) for n in self._allow or ())
        return (f"vilma: commands from {address} are refused; this simulator takes commands only from "
                f"{allowed} (allow_commands_from)")
