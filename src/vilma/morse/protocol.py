"""MORSE socket protocol text: line framing, request parsing, reply formatting.

A request is one line ``<id> <component> <service>[ <params>]`` or ``<id> cancel``;
``params`` is a JSON array of positional arguments. A reply is one line
``<id> <STATUS>[ <json>]`` ending in ``\\n`` (never ``\\r\\n``). The error texts
are MORSE's (``socket_request_manager.py``, ``request_manager.py``), because
pymorse reads them: "wrong # of parameters" becomes a ``TypeError`` there.
See ``reference/morse-protocol.md`` section 2.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

SUCCESS = "SUCCESS"
FAILED = "FAILED"
PREEMPTED = "PREEMPTED"

MANAGER = "Socket service manager"
"""How MORSE names the socket request manager in its error texts."""

MAX_LINE = 65536
"""Longest accepted request or datastream line [bytes]; a longer one is answered FAILED and skipped."""

MALFORMED = "Malformed request! "
"""MORSE's reply text for a line with a single token (sic: trailing space)."""

MALFORMED_TOKENS = ("Malformed request: at least 3 values and at most 4 are expected "
                    "(id, component, service, [params])")


class RequestError(Exception):
    """A request that cannot be served; ``str(e)`` is the FAILED payload (one line)."""


@dataclass(frozen=True, slots=True)
class Request:
    """A parsed service request: ``params`` are the positional arguments (empty when none)."""

    id: str
    component: str
    service: str
    params: tuple[Any, ...]


@dataclass(frozen=True, slots=True)
class Cancel:
    """``<id> cancel``: preempt the running asynchronous request ``id``."""

    id: str


@dataclass(frozen=True, slots=True)
class Invalid:
    """A line that is not a valid request: ``id`` (best effort) and the FAILED ``message``."""

    id: str
    message: str


@dataclass(frozen=True, slots=True)
class TooLong:
    """A line longer than :data:`MAX_LINE`; ``head`` is its first bytes (for the reply id)."""

    head: bytes


class LineBuffer:
    """Splits a byte stream into ``\\n``-terminated lines, keeping partial lines across reads.

    Memory is bounded: a line longer than ``max_line`` bytes is reported once as
    :class:`TooLong` and its remaining bytes are skipped up to the next ``\\n``.
    """

    __slots__ = ("_buf", "_skipping", "max_line")

    def __init__(self, max_line: int = MAX_LINE) -> None:
        self.max_line = max_line
        self._buf = b""
        self._skipping = False

    @property
    def pending(self) -> int:
        """Bytes held of an unfinished line."""
        return len(self._buf)

    def feed(self, data: bytes) -> list[bytes | TooLong]:
        """Complete lines in ``data`` (after what came before), without their ``\\n``."""
        parts = (self._buf + data).split(b"\n")
        self._buf = parts.pop()
        out: list[bytes | TooLong] = []
        for line in parts:
            if self._skipping:  # the end of a line already reported as too long
                self._skipping = False
            elif len(line) > self.max_line:
                out.append(TooLong(line[:80]))
            else:
                out.append(line)
        if len(self._buf) > self.max_line:
            if not self._skipping:
                out.append(TooLong(self._buf[:80]))
                self._skipping = True
            self._buf = b""
        return out

    def end(self) -> list[bytes]:
        """At the end of the stream: its last line if it had no ``\\n`` (one not already skipped as too long)."""
        last, skipping = self._buf, self._skipping
        self._buf, self._skipping = b"", False
        return [last] if last and not skipping else []


def first_token(raw: bytes | str) -> str:
    """The first whitespace-separated token of a line (the request id), or ``?``."""
    text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else raw
    tokens = text.split(None, 1)
    return tokens[0] if tokens else "?"


def parse_request(line: str) -> Request | Cancel | Invalid | None:
    """Parse one request line (without its ``\\n``); None for a blank line.

    Follows ``SocketRequestManager.main`` and ``_parse_request``: the line is
    stripped (so CRLF is fine), split on whitespace into id, component,
    service and the rest, which must be a JSON array (a falsy JSON value or
    nothing means no arguments, as in MORSE).
    """
    line = line.strip()
    if not line:
        return None  # MORSE would answer an empty id; telnet users just pressed Enter
    head = line.split(None, 1)
    if len(head) < 2:
        return Invalid(head[0], MALFORMED)
    rid, rest = head
    if rest == "cancel":
        return Cancel(rid)
    tokens = rest.split(None, 2)
    if len(tokens) < 2:
        return Invalid(rid, MALFORMED_TOKENS)
    component, service = tokens[0], tokens[1]
    raw = tokens[2].strip() if len(tokens) == 3 else ""
    if not raw:
        return Request(rid, component, service, ())
    try:
        params = json.loads(raw)
    except ValueError as e:  # JSONDecodeError, and RecursionError-free by json's own limits
        return Invalid(rid, f"Invalid request syntax: error while parsing the parameters: <{raw}>. {e}")
    except RecursionError:
        return Invalid(rid, f"Invalid request syntax: error while parsing the parameters: <{raw[:80]}...>. "
                            "nested too deeply")
    if not params:
        return Request(rid, component, service, ())
    if not isinstance(params, list):
        return Invalid(rid, f"Invalid request syntax: error while parsing the parameters: <{raw}>. "
                            f"The parameters must be a JSON array of positional arguments, e.g. [1, 0.3]")
    return Request(rid, component, service, tuple(params))


def format_reply(rid: str, status: str, result: Any = None) -> bytes:
    """One reply line, ``\\n``-terminated. As MORSE, a falsy result (None, 0, [], "") sends no payload."""
    if result:
        try:
            payload = json.dumps(result)
        except (TypeError, ValueError) as e:  # never expected: results are built from plain types
            status, payload = FAILED, json.dumps(f"vilma could not encode the result as JSON: {e}")
        return f"{rid} {status} {payload}\n".encode()
    return f"{rid} {status}\n".encode()


def wrong_count(service: str, names: tuple[str, ...], given: int) -> str:
    """MORSE's text for a wrong number of arguments (pymorse raises TypeError on it)."""
    expect = f"[{', '.join(names)}]" if names else "[] (no arguments)"
    return (f"{MANAGER}: wrong # of parameters for service {service}. {service}() takes {len(names)} "
            f"argument{'s' if len(names) != 1 else ''} but {given} {'was' if given == 1 else 'were'} given; "
            f"send {expect}")


def missing_params(service: str, names: tuple[str, ...]) -> str:
    """MORSE's text for a service called without the arguments it needs."""
    return (f"{MANAGER}: parameters expected for service {service}! {service}() takes "
            f"{len(names)} argument{'s' if len(names) != 1 else ''}: send [{', '.join(names)}]")


def wrong_type(service: str, detail: str) -> str:
    """MORSE's text for an argument of the wrong type or value."""
    return f"{MANAGER}: wrong parameter type for service {service}. {detail}"


def not_registered(service: str) -> str:
    """MORSE's text for an unknown component or service."""
    return f"The request {service} has not been registered in {MANAGER}"
