"""The listening sockets of a MORSE interface: the service port, then one datastream port per component, each the
first free from where it was asked, as MORSE places them (``reference/morse-protocol.md`` section 1)."""

from __future__ import annotations

import errno
import socket
from collections.abc import Iterable

SERVICE_PORT_TRIES = 10
"""Service ports tried from ``service_port`` on (MORSE: 4000-4009)."""
STREAM_PORT_TRIES = 100
"""Busy ports skipped at most when placing one datastream."""


class ListenError(OSError):
    """The server cannot listen where it was asked: ``argument`` names the one to change (``host``,
    ``service_port`` or ``stream_port``), ``reason`` says why and how."""

    def __init__(self, argument: str, reason: str) -> None:
        super().__init__(f"{argument}: {reason}")
        self.argument, self.reason = argument, reason


def listen(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port`` (port 0: any free); OSError when busy."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    s = socket.socket(family, socket.SOCK_STREAM)
    try:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((host, port))
        s.listen(128)
        s.setblocking(False)
    except BaseException:
        s.close()
        raise
    return s


def bind_ports(host: str, service_port: int, stream_port: int, streams: Iterable[str]) -> dict[str, socket.socket]:
    """Listening sockets on ``host``: the service port (key ``""``; the first free of ``service_port .. +9``),
    then one for each of ``streams`` in order, on the first free port after the one before (from ``stream_port``);
    0 for either: any free ports. :class:`ListenError` when they cannot all be had."""
    streams = list(streams)
    n = len(streams)
    if stream_port + n - 1 > 65535:
        raise ListenError("stream_port", f"the {n} datastreams take consecutive ports from {stream_port}, past "
                                         f"65535: start at {65536 - n} at most, or 0 for any free ports")
    socks: dict[str, socket.socket] = {}
    try:
        last = min(service_port + SERVICE_PORT_TRIES - 1, 65535) if service_port else 0
        sock = _first_free(host, service_port, last, "service_port")
        if sock is None:
            raise ListenError("service_port", f"MORSE service ports {service_port}-{last} on {host} are all in use: "
                                              f"stop the other simulator, or start from another port (0: any free)")
        socks[""] = sock
        port = stream_port
        for fqn in streams:
            last = min(port + STREAM_PORT_TRIES - 1, 65535) if port else 0
            sock = _first_free(host, port, last, "stream_port")
            if sock is None:  # (port is past 65535 when the streams before skipped busy ports up to there)
                span = f"in {port}-{last}" if port <= last else "up to 65535"
                raise ListenError("stream_port", f"no free port for the {fqn} datastream {span} on {host}: start "
                                                 f"from another port (0: any free)")
            socks[fqn] = sock
            if port:
                port = sock.getsockname()[1] + 1
    except BaseException:
        for s in socks.values():
            s.close()
        raise
    return socks


def _first_free(host: str, first: int, last: int, argument: str) -> socket.socket | None:
    """A socket listening on the first port of ``first .. last`` not in use (MORSE's way), or None; any other
    failure is a :class:`ListenError` blaming ``host`` or ``argument``."""
    for port in range(first, last + 1):
        try:
            return listen(host, port)
        except OSError as e:
            if e.errno == errno.EADDRINUSE:
                continue
            if isinstance(e, socket.gaierror) or e.errno in (errno.EADDRNOTAVAIL, errno.EAFNOSUPPORT):
                raise ListenError("host", f"cannot listen on {host}: {e.strerror}; give an address of this machine, "
                                          f"e.g. 127.0.0.1") from None
            raise ListenError(argument, f"cannot listen on port {port} of {host}: {e.strerror}") from None
    return None
