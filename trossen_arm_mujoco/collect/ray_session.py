"""Starting or joining the Ray instance that ``record --engine ray`` runs its episodes on.

Ray is optional (``pip install ".[ray]"``) and imported only here. Without an address a
private local Ray is started that stays on this machine: node address 127.0.0.1, usage
statistics and the cloud-metadata probe off (a private ``HOME`` with an empty
``ray_bootstrap_config.yaml`` and the cluster's token), no dashboard, token authentication
on. With an address (``auto``, ``host:port`` of a ``ray start --head`` node, or
``ray://host:port``) that cluster is joined as it is configured.

Docs: docs/cli/record.md (Recording on a Ray cluster); details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import logging
import os
import shutil
import socket
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType

from trossen_arm_mujoco.errors import UserError

__all__ = [
    "CONNECT_TIMEOUT_S",
    "LOCAL_RAY_ENV",
    "RAY_MISSING",
    "check_reachable",
    "import_ray",
    "is_loopback_node",
    "ray_session",
]

RAY_MISSING = 'the Ray engine needs Ray: pip install ".[ray]" in the trossen_arm_mujoco checkout'

#: Environment of a private local Ray (see the module docstring).
LOCAL_RAY_ENV = {
    # 0: the node address is the loopback address, and no route probe is made
    "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0",
    "RAY_USAGE_STATS_ENABLED": "0",
}

#: Seconds to wait for a ``host:port`` address to accept a connection before ``ray.init``
#: (which would otherwise retry for minutes).
CONNECT_TIMEOUT_S = 5.0


def import_ray() -> ModuleType:
    """The ``ray`` module, or a one-line :class:`UserError` saying how to install it."""
    try:
        import ray
    except ImportError:
        raise UserError(RAY_MISSING) from None
    return ray


def check_reachable(address: str, timeout: float = CONNECT_TIMEOUT_S) -> None:
    """Fail fast when a ``host:port`` or ``ray://host:port`` address accepts no connection;
    ``auto`` and ``local`` are left to Ray."""
    if address in ("auto", "local"):
        return
    hostport = address.removeprefix("ray://")
    host, sep, port = hostport.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise UserError(
            f"--ray_address must be 'auto', HOST:PORT or ray://HOST:PORT, got '{address}'"
        )
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout).close()
    except OSError as exc:
        raise UserError(
            f"cannot reach the Ray cluster at {address}: {exc.strerror or exc}; start it with "
            "'ray start --head' on the head node, or leave out --ray_address for a local Ray"
        ) from None


@contextmanager
def _local_ray_environment(ray: ModuleType) -> Iterator[None]:
    """Set :data:`LOCAL_RAY_ENV` and a private ``HOME`` (holding an empty
    ``ray_bootstrap_config.yaml``) for the local Ray's processes; restore both at the end."""
    home = Path(tempfile.mkdtemp(prefix="trossen-ray-home-"))
    (home / "ray_bootstrap_config.yaml").write_text("{}\n")
    changes = {**LOCAL_RAY_ENV, "HOME": str(home)}
    saved = {name: os.environ.get(name) for name in changes}
    os.environ.update(changes)
    # This process read RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER when it imported ray (the Ray
    # processes started below read it from the environment): apply it here too.
    constants = getattr(getattr(ray, "_private", None), "ray_constants", None)
    cluster = getattr(constants, "ENABLE_RAY_CLUSTER", None)
    if cluster is not None:
        constants.ENABLE_RAY_CLUSTER = False
    try:
        yield
    finally:
        if cluster is not None:
            constants.ENABLE_RAY_CLUSTER = cluster
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
        shutil.rmtree(home, ignore_errors=True)


def _start_local(ray: ModuleType, num_cpus: int | None) -> None:
    ray.init(
        address="local",
        num_cpus=num_cpus,
        include_dashboard=False,
        _node_ip_address="127.0.0.1",
        logging_level=logging.WARNING,
    )
    if not is_loopback_node(ray):
        ray.shutdown()
        raise UserError("the local Ray did not start on the loopback address 127.0.0.1")


@contextmanager
def ray_session(address: str | None = None, num_cpus: int | None = None) -> Iterator[ModuleType]:
    """Yield the ``ray`` module connected to a Ray instance, and disconnect at the end.

    Args:
        address: ``None`` starts a private local Ray on loopback (see the module docstring);
            otherwise ``"auto"``, ``"host:port"`` or ``"ray://host:port"`` of a running
            cluster.
        num_cpus: CPUs of a local Ray (``None``: all cores); ignored with an address.

    An instance this process is already connected to (``ray.is_initialized()``) is used as
    it is and left running.
    """
    ray = import_ray()
    if ray.is_initialized():
        yield ray
        return
    if address is None:
        with _local_ray_environment(ray):
            _start_local(ray, num_cpus)
            try:
                yield ray
            finally:
                ray.shutdown()
        return
    check_reachable(address)
    try:
        ray.init(address=address, logging_level=logging.WARNING)
    except (ConnectionError, RuntimeError, ValueError) as exc:
        raise UserError(f"cannot connect to the Ray cluster at {address}: {exc}") from None
    try:
        yield ray
    finally:
        ray.shutdown()


def is_loopback_node(ray: ModuleType) -> bool:
    """Whether every node of the connected Ray instance has a loopback address."""
    import ipaddress

    addresses = [node["NodeManagerAddress"] for node in ray.nodes() if node.get("Alive")]
    return bool(addresses) and all(ipaddress.ip_address(a).is_loopback for a in addresses)
