"""The test guard itself: non-loopback connections fail the test, loopback works."""

from __future__ import annotations

import socket

import pytest


@pytest.mark.parametrize(
    "connect",
    [
        lambda: socket.create_connection(("192.168.1.5", 1), timeout=0.01),
        lambda: socket.socket(socket.AF_INET, socket.SOCK_STREAM).connect(("192.168.1.4", 1)),
        lambda: socket.socket(socket.AF_INET, socket.SOCK_STREAM).connect_ex(("192.0.2.1", 1)),
        lambda: socket.socket(socket.AF_INET6, socket.SOCK_STREAM).connect(("2001:db8::1", 1)),
        lambda: socket.create_connection(("example.invalid", 1), timeout=0.01),
    ],
)
def test_non_loopback_connect_fails_the_test(connect, no_network: list[str]) -> None:
    with pytest.raises(pytest.fail.Exception, match="non-loopback"):
        connect()
    assert len(no_network) == 1
    no_network.clear()  # the violation was intended


def test_loopback_is_allowed(no_network: list[str]) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        port = server.getsockname()[1]
        with socket.create_connection(("127.0.0.1", port), timeout=1.0):
            pass
        with socket.create_connection(("localhost", port), timeout=1.0):
            pass
    assert no_network == []
