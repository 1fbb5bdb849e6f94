"""The suite's network guard (tests/conftest.py) blocks non-loopback addresses, and only those."""

from __future__ import annotations

import shutil
import socket
import subprocess
import sys
import threading
from pathlib import Path

import pytest

REMOTE = ("192.168.1.5", 50000)  # the default left-arm IP of the real kit


@pytest.fixture
def blocked_error(network_guard):
    """The guard's exception type; the attempts a test provokes are cleared afterwards."""
    yield network_guard.error_type
    network_guard.blocked.clear()


def _unbound(sock: socket.socket) -> bool:
    """True when the kernel never saw a connect: no local port was ever assigned."""
    return sock.getsockname()[1] == 0


def test_connect_to_lan_address_raises_before_any_packet(blocked_error):
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        with pytest.raises(blocked_error, match=r"192\.168\.1\.5"):
            sock.connect(REMOTE)
        assert _unbound(sock)  # a real connect attempt would have bound an ephemeral port
        with pytest.raises(OSError):
            sock.getpeername()


def test_connect_ex_and_udp_are_blocked(blocked_error):
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        with pytest.raises(blocked_error, match=r"192\.168\.1\.5"):
            sock.connect_ex(REMOTE)
        assert _unbound(sock)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp:
        with pytest.raises(blocked_error, match=r"192\.168\.1\.5"):
            udp.sendto(b"x", REMOTE)
        with pytest.raises(blocked_error):
            udp.connect(REMOTE)
        assert _unbound(udp)  # neither sendto nor connect reached the kernel


def test_create_connection_blocked_before_dns(blocked_error, monkeypatch):
    def no_dns(*args, **kwargs):
        raise AssertionError("getaddrinfo must not be called for a blocked address")

    monkeypatch.setattr(socket, "getaddrinfo", no_dns)
    with pytest.raises(blocked_error, match=r"192\.168\.1\.5"):
        socket.create_connection(REMOTE, timeout=0.1)
    with pytest.raises(blocked_error, match="example.invalid"):
        socket.create_connection(("example.invalid", 80), timeout=0.1)


def test_swallowed_attempts_are_recorded(network_guard):
    try:
        socket.create_connection(REMOTE, timeout=0.1)
    except Exception:
        pass  # code under test that hides the error still leaves a record
    assert len(network_guard.blocked) == 1
    assert "192.168.1.5" in network_guard.blocked[0]
    network_guard.blocked.clear()


def test_loopback_connection_allowed():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        port = server.getsockname()[1]
        received = []

        def serve():
            conn, _ = server.accept()
            with conn:
                received.append(conn.recv(16))

        thread = threading.Thread(target=serve, daemon=True)
        thread.start()
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as client:
            client.settimeout(5)
            client.connect(("127.0.0.1", port))
            client.sendall(b"ping")
        thread.join(5)
        assert received == [b"ping"]
        with socket.create_connection(("localhost", port), timeout=5):
            pass  # "localhost" is allowed too (accept queue holds it)


def test_unix_socket_allowed(tmp_path):
    path = str(tmp_path / "s.sock")
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as server:
        server.bind(path)
        server.listen(1)
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as client:
            client.connect(path)


@pytest.mark.parametrize(
    ("address", "expected"),
    [
        (("127.0.0.1", 1), True),
        (("127.3.4.5", 1), True),
        (("::1", 1, 0, 0), True),
        (("::ffff:127.0.0.1", 1, 0, 0), True),
        (("localhost", 1), True),
        (("LOCALHOST", 1), True),
        (("192.168.1.5", 1), False),
        (("10.0.0.1", 1), False),
        (("8.8.8.8", 53), False),
        (("2001:db8::1", 1, 0, 0), False),
        (("example.com", 80), False),
        (("0.0.0.0", 80), False),
    ],
)
def test_loopback_classification(network_guard, address, expected):
    family = socket.AF_INET6 if ":" in address[0] else socket.AF_INET
    assert network_guard.allows(family, address) is expected


def test_guard_error_is_not_an_oserror(network_guard):
    # Retry loops that catch OSError must not silently swallow a blocked connection.
    assert not issubclass(network_guard.error_type, OSError)


def test_ipv6_loopback_allowed():
    if not socket.has_ipv6:
        pytest.skip("no IPv6 support in this Python build")
    try:
        server = socket.socket(socket.AF_INET6, socket.SOCK_STREAM)
        server.bind(("::1", 0))
    except OSError as exc:
        pytest.skip(f"IPv6 loopback unavailable here: {exc}")
    with server:
        server.listen(1)
        with socket.socket(socket.AF_INET6, socket.SOCK_STREAM) as client:
            client.connect(("::1", server.getsockname()[1]))


def test_swallowed_attempt_fails_the_test(tmp_path):
    """A test that hides a blocked connection still fails (run in a separate pytest)."""
    shutil.copy(Path(__file__).with_name("conftest.py"), tmp_path / "conftest.py")
    (tmp_path / "test_hidden.py").write_text(
        "import socket\n\n"
        "def test_hidden():\n"
        "    try:\n"
        "        socket.create_connection(('192.168.1.5', 80), timeout=0.1)\n"
        "    except Exception:\n"
        "        pass\n"
    )
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode != 0, proc.stdout
    assert "the test tried to reach the network" in proc.stdout
    assert "192.168.1.5" in proc.stdout
