"""Which addresses stay on this machine."""

from vilma.core.net import is_loopback


def test_loopback_addresses():
    assert all(is_loopback(h) for h in ("127.0.0.1", "127.8.9.1", "localhost", "::1", "[::1]"))
    assert not any(is_loopback(h) for h in ("0.0.0.0", "", "10.0.0.5", "::", "example.org", "192.168.1.2"))
