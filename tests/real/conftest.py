"""Fixtures of the real-replay tests, and two guards that keep them off real hardware.

Guards (autouse, every test in this folder):

- ``no_network``: ``socket.socket.connect``/``connect_ex`` and ``socket.create_connection``
  fail the test (``pytest.fail``, which ``except Exception`` cannot swallow) for any
  address that is not loopback (127.0.0.0/8, ::1, localhost) or a unix socket; a
  violation is also re-checked at teardown.
- ``no_real_configure``: ``TrossenArmDriver.configure`` fails the test for any address
  that is not loopback, since the C++ ``trossen_arm`` driver opens its own sockets, out of
  reach of the socket guard (loopback addresses are the simulated kit served by
  ``trossen_arm_mujoco.twin``, never a real arm).
"""

from __future__ import annotations

import ipaddress
import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from trossen_arm_mujoco.constants import START_ARM_POSE
from trossen_arm_mujoco.real import driver as driver_module

FIXTURES = Path(__file__).parents[1] / "fixtures"
VENDOR_600 = FIXTURES / "vendor_transfer_cube_600steps_noimages.hdf5"


def _allowed(address: Any) -> bool:
    """True for unix-socket paths and loopback hosts."""
    if isinstance(address, (str, bytes)):
        return True  # AF_UNIX
    host = address[0] if isinstance(address, tuple) and address else address
    if isinstance(host, bytes):
        host = host.decode(errors="replace")
    if not isinstance(host, str):
        return False
    if host.lower() in ("localhost", "ip6-localhost"):
        return True
    try:
        ip = ipaddress.ip_address(host.split("%", 1)[0])
    except ValueError:
        return False
    mapped = getattr(ip, "ipv4_mapped", None)
    return ip.is_loopback or bool(mapped and mapped.is_loopback)


@pytest.fixture(autouse=True)
def no_network(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[str]]:
    """Fail the test on any connection to a non-loopback address.

    Yields the list of refused addresses (the guard's own test empties it).
    """
    violations: list[str] = []

    def refuse(address: Any) -> None:
        violations.append(repr(address))
        pytest.fail(f"test tried to connect to a non-loopback address {address!r}", pytrace=True)

    real_connect, real_connect_ex = socket.socket.connect, socket.socket.connect_ex
    real_create = socket.create_connection

    def connect(self: socket.socket, address: Any) -> Any:
        if not _allowed(address):
            refuse(address)
        return real_connect(self, address)

    def connect_ex(self: socket.socket, address: Any) -> Any:
        if not _allowed(address):
            refuse(address)
        return real_connect_ex(self, address)

    def create_connection(address: Any, *args: Any, **kwargs: Any) -> socket.socket:
        if not _allowed(address):
            refuse(address)
        return real_create(address, *args, **kwargs)

    monkeypatch.setattr(socket.socket, "connect", connect)
    monkeypatch.setattr(socket.socket, "connect_ex", connect_ex)
    monkeypatch.setattr(socket, "create_connection", create_connection)
    yield violations
    assert not violations, f"non-loopback connections attempted: {violations}"


@pytest.fixture(autouse=True)
def no_real_configure(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail the test if anything configures a real arm (any address but loopback)."""
    real = driver_module.TrossenArmDriver.configure

    def refuse(self: Any, ip_address: str, *args: Any, **kwargs: Any) -> None:
        if not _allowed((ip_address, 0)):
            pytest.fail(f"test tried to configure a real arm at {ip_address!r}")
        return real(self, ip_address, *args, **kwargs)

    monkeypatch.setattr(driver_module.TrossenArmDriver, "configure", refuse)


def smooth_actions(num_steps: int = 20, fps: float = 10.0) -> np.ndarray:
    """A smooth ``(T, 16)`` trajectory from START_ARM_POSE, within limits at ``fps``.

    Joints 0, 3, 4, 5 swing by up to 0.3 rad, joints 1, 2 lift by 0.3 rad, grippers
    close from 0.044 to 0.03 m; peak speeds stay far below the limits.
    """
    t = np.arange(num_steps) / fps
    s = 0.5 - 0.5 * np.cos(np.pi * t / max(t[-1], 1e-9))  # 0 -> 1, smooth
    base = np.asarray(START_ARM_POSE, dtype=np.float64)
    out = np.tile(base, (num_steps, 1))
    for off, sign in ((0, 1.0), (8, -1.0)):
        out[:, off + 0] += sign * 0.3 * s
        out[:, off + 1] += 0.3 * s
        out[:, off + 2] += 0.3 * s
        out[:, off + 3] += 0.2 * s
        out[:, off + 4] += sign * 0.2 * s
        out[:, off + 5] += 0.3 * s
        out[:, off + 6] = out[:, off + 7] = 0.044 - 0.014 * s
    return out


@pytest.fixture
def smooth() -> Callable[..., np.ndarray]:
    """:func:`smooth_actions`, as a fixture."""
    return smooth_actions


@pytest.fixture
def vendor_path() -> Path:
    """The vendor 600-step episode (shared fixture: copy it before modifying)."""
    return VENDOR_600
