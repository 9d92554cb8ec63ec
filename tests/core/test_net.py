"""Which addresses stay on this machine; Zenoh's endpoints."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from vilma.core.net import check_endpoint, is_loopback


def test_loopback_addresses():
    assert all(is_loopback(h) for h in ("127.0.0.1", "127.8.9.1", "localhost", "::1", "[::1]"))
    assert not any(is_loopback(h) for h in ("0.0.0.0", "", "10.0.0.5", "::", "example.org", "192.168.1.2"))


@given(st.text(max_size=40), st.booleans())
def test_any_text_is_an_endpoint_or_a_line_that_does_not_quote_it(text, listen):
    endpoint = f"tcp/{text}hunter2"  # (the secret a file given by mistake may hold)
    try:
        check_endpoint(endpoint, listen)
    except ValueError as e:
        assert "\n" not in str(e) and "hunter2" not in str(e)


@pytest.mark.parametrize("endpoint", ["tcp/127.0.0.1:7447", "tcp/localhost:7447", "tcp/[::1]:7447", "udp/10.0.0.5:7451",
                                      "tcp/0.0.0.0:7447#iface=lo", "unixsock-stream//tmp/zenoh.sock"])
def test_zenohs_endpoints_are_taken(endpoint):
    check_endpoint(endpoint, listen=False)

