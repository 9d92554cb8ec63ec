"""The command line's number, port and endpoint types: a value is taken exactly when it is in range, else one
argparse line; the Zenoh configuration file, whose errors never show what it holds."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.app.options import (
    SCHEDULER_PROTOCOLS,
    connect_endpoint,
    count,
    duration,
    listen_endpoint,
    non_negative,
    port,
    port_or_any,
    positive,
    scheduler,
    sim_time,
    wall_delay,
    zenoh_config_file,
)
from vilma.bus.zenoh_bus import ZenohConfig
from vilma.core.clock import MAX_NS, NS_PER_S

FLOATS = {
    positive: lambda v: 0 < v < math.inf,
    non_negative: lambda v: 0 <= v < math.inf,
    duration: lambda v: v > 0,  # inf: no end
    sim_time: lambda v: 0 <= v < MAX_NS / NS_PER_S,  # the clock counts int64 ns
    wall_delay: lambda v: 0 < v <= (2**31 - 1) / 1000,  # a Qt timer counts int32 ms
}
INTS = {count: lambda v: v >= 1, port: lambda v: 1 <= v <= 65535, port_or_any: lambda v: 0 <= v <= 65535}


def _one_line_refusal(kind, text: str) -> str:
    with pytest.raises(argparse.ArgumentTypeError) as e:
        kind(text)
    assert "\n" not in str(e.value)
    return str(e.value)


EDGES = [0.0, -0.0, 1e-300, 1e300, 2147483.647, 2147483.648, 9.2e9, 9.3e9]
"""Values at the limits: zero, the Qt timer's int32 ms, the clock's int64 ns."""


@given(st.sampled_from(list(FLOATS)), st.floats() | st.sampled_from(EDGES))
def test_float_options_take_exactly_the_values_in_range(kind, value):
    text = repr(value)
    if FLOATS[kind](value):
        assert kind(text) == value
    else:
        assert _one_line_refusal(kind, text) == f"must be {_need(kind)}, got {text}"


@given(st.sampled_from(list(INTS)), st.integers(-100_000, 100_000))
def test_int_options_take_exactly_the_values_in_range(kind, value):
    if INTS[kind](value):
        assert kind(str(value)) == value
    else:
        assert _one_line_refusal(kind, str(value)).startswith("must be ")


@given(st.sampled_from([*FLOATS, *INTS]), st.text(max_size=12))
def test_any_text_is_a_number_in_range_or_one_argparse_line(kind, text):
    try:
        value = kind(text)
    except argparse.ArgumentTypeError as e:
        assert "\n" not in str(e) and (str(e).startswith("must be ") or str(e).startswith("expected a"))
        return
    assert (FLOATS | INTS)[kind](value)


def test_whole_numbers_are_whole():
    assert _one_line_refusal(port, "80.5") == "expected a whole number, got '80.5'"
    assert _one_line_refusal(positive, "fast") == "expected a number, got 'fast'"


@given(protocol=st.sampled_from(["", "tcp://", "tls://", "ws://", "http://", "inproc://", "tcp:/"]),
       host=st.sampled_from(["", "127.0.0.1", "[::1]", "node-7.cluster"]), number=st.integers(-10, 70_000))
def test_a_scheduler_address_is_taken_exactly_with_a_known_protocol_a_host_and_a_port(protocol, host, number):
    text = f"{protocol}{host}:{number}"
    if protocol.removesuffix("://") in ("", *SCHEDULER_PROTOCOLS) and host and 1 <= number <= 65535:
        assert scheduler(text) == text
    else:
        assert _one_line_refusal(scheduler, text)


@pytest.mark.parametrize(("text", "message"), [
    ("tcp://127.0.0.1:99999", "port 99999 of 'tcp://127.0.0.1:99999' must be a TCP port, 1-65535"),
    ("http://x", "unknown protocol 'http' in 'http://x'; use one of tcp, tls, ws, wss, ucx, e.g. tcp://host:8786"),
    ("garbage", "expected a Dask scheduler's address, HOST:PORT or tcp://HOST:PORT (as `dask scheduler` prints it), "
                "got 'garbage'"),
])
def test_a_malformed_scheduler_address_says_what_is_wrong(text, message):
    assert _one_line_refusal(scheduler, text) == message


def _need(kind) -> str:
    """The range each type states in its refusal."""
    return {positive: "a finite number > 0", non_negative: "a finite number >= 0",
            duration: "a number of seconds > 0 (inf: no end)", sim_time: "a number of seconds in [0, 9.22e+09)",
            wall_delay: "a number of seconds in (0, 2147483.647]"}[kind]


@given(st.integers(-100_000, 100_000))
def test_endpoints_take_exactly_the_ports_in_range_and_0_only_to_listen(value):
    text = f"tcp/127.0.0.1:{value}"
    for kind, low in ((listen_endpoint, 0), (connect_endpoint, 1)):
        if low <= value <= 65535:
            assert kind(text) == text
        else:
            assert _one_line_refusal(kind, text).startswith(f"{text!r}: the port must be a whole number 1-65535")


@pytest.mark.parametrize(("text", "why"), [
    ("garbage", "not an endpoint: give <protocol>/<address>, e.g. tcp/127.0.0.1:7447"),
    ("tcp/127.0.0.1:abc", "the port must be a whole number 1-65535"),
    ("tcp/127.0.0.1", "no port: give <host>:<port> after the protocol, e.g. tcp/127.0.0.1:7447"),
    ("tcp/999.0.0.1:7447", "the host must be a name, an IPv4 address or an [IPv6] address"),
    ("tcp/[127.0.0.1]:7447", "the host must be a name, an IPv4 address or an [IPv6] address"),
    ("http/127.0.0.1:7447", "unknown protocol: use one of tcp, udp, tls, quic, ws, unixsock-stream, unixpipe"),
])
def test_an_endpoint_zenoh_would_not_take_or_never_reach_is_one_argparse_line(text, why):
    assert _one_line_refusal(connect_endpoint, text).startswith(f"{text!r}: {why}")


@pytest.mark.parametrize("text", ["tcp/localhost:7447", "tcp/[::1]:7447", "udp/10.0.0.5:7451?iface=eth0",
                                  "tls/example.org:7447", "unixsock-stream//tmp/zenoh.sock"])
def test_the_endpoints_zenoh_takes_are_taken(text):
    assert connect_endpoint(text) == listen_endpoint(text) == text


SECRET = "hunter2"
"""What a file given by mistake holds (a parser quoting it would show it)."""


@pytest.mark.parametrize(("text", "error"), [
    (f"root:{SECRET}:0:0:root:/root:/bin/bash\n", "{file}: not a Zenoh configuration: expected a mapping of listen, "
                                                  "connect, multicast_scouting, extra"),
    (f"- {SECRET}\n", "{file}: not a Zenoh configuration"),
    (f"listen: [tcp/127.0.0.1:0]\n{SECRET}: 1\n", "{file}:2: unknown key; the keys are listen, connect, "
                                                   "multicast_scouting, extra"),
    (f"listen: {SECRET}\n", "{file}:1: listen: expected a list of endpoints, e.g. [tcp/127.0.0.1:7447]"),
    (f"connect:\n  - tcp/127.0.0.1:7447\n  - tcp/{SECRET}:abc\n", "{file}:3: connect[1]: the port must be a "
                                                                     "whole number 1-65535"),
    (f"multicast_scouting: {SECRET}\n", "{file}:1: multicast_scouting: expected true or false"),
    (f"extra: [[{SECRET}]]\n", "{file}:1: extra: expected a list of [key path, JSON5 value] pairs of text"),
])
def test_a_zenoh_config_file_error_is_located_and_never_shows_the_file(tmp_path, text, error):
    file = tmp_path / "z.yaml"
    file.write_text(text)
    with pytest.raises(ValueError) as e:
        zenoh_config_file(file, ZenohConfig())
    assert str(e.value).startswith(error.format(file=file)) and SECRET not in str(e.value)


def test_a_zenoh_config_file_sets_what_it_names(tmp_path):
    file = tmp_path / "z.yaml"
    file.write_text("connect: [tcp/127.0.0.1:7447]\nextra: [[transport/unicast/max_links, '2']]\n")
    base = ZenohConfig(listen=("tcp/127.0.0.1:0",), multicast_scouting=True)
    assert zenoh_config_file(file, base) == ZenohConfig(
        listen=("tcp/127.0.0.1:0",), connect=("tcp/127.0.0.1:7447",), multicast_scouting=True,
        extra=(("transport/unicast/max_links", "2"),))
    assert zenoh_config_file(Path("/dev/null"), base) == base  # an empty file changes nothing

