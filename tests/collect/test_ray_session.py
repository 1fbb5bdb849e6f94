"""Starting or joining Ray: install hint, address checks, the local Ray's environment. None
of these tests starts Ray (tests/collect/test_ray_engine.py does, once)."""

from __future__ import annotations

import os
import socket
import sys
from pathlib import Path

import pytest

from trossen_arm_mujoco.collect import ray_session
from trossen_arm_mujoco.errors import UserError


def test_missing_ray_is_a_one_line_install_hint(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    with pytest.raises(UserError) as info:
        ray_session.import_ray()
    assert (
        str(info.value)
        == 'the Ray engine needs Ray: pip install ".[ray]" in the trossen_arm_mujoco checkout'
    )


@pytest.mark.parametrize("address", ["nonsense", "ray://", "host:port", ":6379"])
def test_malformed_address_is_rejected(address):
    with pytest.raises(UserError, match="--ray_address must be 'auto', HOST:PORT"):
        ray_session.check_reachable(address)


def test_unreachable_address_fails_fast_with_hint():
    with socket.socket() as probe:  # a loopback port that nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    for address in (f"127.0.0.1:{port}", f"ray://127.0.0.1:{port}"):
        with pytest.raises(UserError, match=f"cannot reach the Ray cluster at {address}: "):
            ray_session.check_reachable(address, timeout=2.0)


def test_listening_address_passes_and_auto_is_left_to_ray(monkeypatch):
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        port = server.getsockname()[1]
        ray_session.check_reachable(f"127.0.0.1:{port}")
        ray_session.check_reachable(f"ray://localhost:{port}")

    def no_connection(*args, **kwargs):
        raise AssertionError("'auto' must not be probed")

    monkeypatch.setattr(socket, "create_connection", no_connection)
    ray_session.check_reachable("auto")


def test_local_environment_is_set_then_restored(monkeypatch):
    ray = pytest.importorskip("ray")
    monkeypatch.setenv("HOME", "/home/someone")
    monkeypatch.delenv("RAY_USAGE_STATS_ENABLED", raising=False)
    constants = ray._private.ray_constants
    before = constants.ENABLE_RAY_CLUSTER
    with ray_session._local_ray_environment(ray):
        home = Path(os.environ["HOME"])
        assert (home / "ray_bootstrap_config.yaml").read_text() == "{}\n"
        for name, value in ray_session.LOCAL_RAY_ENV.items():
            assert os.environ[name] == value
        assert constants.ENABLE_RAY_CLUSTER is False
    assert os.environ["HOME"] == "/home/someone"
    assert "RAY_USAGE_STATS_ENABLED" not in os.environ
    assert constants.ENABLE_RAY_CLUSTER == before
    assert not home.exists()
