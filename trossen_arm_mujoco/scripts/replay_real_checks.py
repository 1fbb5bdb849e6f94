"""What ``trossen-mujoco replay-real``'s flags choose, checked before any driver exists: the
numbers in range, the arms' addresses (loopback for ``--backend wire``), the end-effector
preset against the installed ``trossen_arm``, the episode file and the output folder. Each
problem is one line (``UserError``) naming the flag; nothing has connected or moved yet.

Docs: docs/cli/replay-real.md.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from trossen_arm_mujoco.collect.resume import format_indices
from trossen_arm_mujoco.data.reader import Episode, episode_path, list_episodes
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.driver import (
    DEFAULT_END_EFFECTOR,
    check_end_effector,
    find_trossen_arm,
    import_trossen_arm,
)
from trossen_arm_mujoco.real.preflight import check_arm_ips
from trossen_arm_mujoco.real.replay import check_fps
from trossen_arm_mujoco.real.validate import ArmLimits

__all__ = [
    "IP_FLAGS",
    "MAX_CONNECT_TIMEOUT_S",
    "arm_ips",
    "check_numbers",
    "end_effector_note",
    "find_episode",
    "output_dir",
]

#: Longest ``--connect_timeout`` (s).
MAX_CONNECT_TIMEOUT_S: float = 600.0

#: The flag that sets each arm's address.
IP_FLAGS: dict[str, str] = {"left": "--left_ip", "right": "--right_ip"}


def check_numbers(args: argparse.Namespace) -> ArmLimits:
    """``--fps``, ``--goal_time_factor``, ``--gripper_max`` (at most the gripper's upper
    limit), ``--connect_timeout``, ``--episode_idx`` and ``--output_dir`` in range: a
    one-line ``UserError`` naming the flag otherwise. Returns the arms' limits
    (``ArmLimits.from_mjcf()``), which bound ``--gripper_max``."""
    check_fps(args.fps)
    if not (math.isfinite(args.goal_time_factor) and 0 < args.goal_time_factor <= 20):
        raise UserError(f"--goal_time_factor must be in (0, 20], got {args.goal_time_factor:g}")
    limits = ArmLimits.from_mjcf()
    top = float(limits.driver_upper[-1])
    if not (math.isfinite(args.gripper_max) and 0 < args.gripper_max <= top):
        raise UserError(f"--gripper_max must be in (0, {top:g}] m, got {args.gripper_max:g}")
    timeout = args.connect_timeout
    if not (math.isfinite(timeout) and 0 < timeout <= MAX_CONNECT_TIMEOUT_S):
        raise UserError(
            f"--connect_timeout must be in (0, {MAX_CONNECT_TIMEOUT_S:g}] s, got {timeout:g}"
        )
    if args.episode_idx < 0:
        raise UserError(f"--episode_idx must be >= 0, got {args.episode_idx}")
    if args.output_dir is not None and not str(args.output_dir).strip():
        raise UserError(
            "--output_dir must not be empty; give a folder, or leave the flag out to write "
            "next to the episode (<data folder>/replay)"
        )
    return limits


def arm_ips(args: argparse.Namespace) -> dict[str, str]:
    """The arms' addresses: the flags, else the backend's defaults; checked before anything
    connects (IPv4, one per arm; loopback for wire), a one-line error naming the flag."""
    wire = args.backend == "wire"
    default = (
        {"left": "127.0.0.2", "right": "127.0.0.3"}
        if wire
        else {"left": "192.168.1.5", "right": "192.168.1.4"}
    )
    given = {"left": args.left_ip, "right": args.right_ip}
    ips = {side: default[side] if given[side] is None else given[side] for side in given}
    if not wire:
        return check_arm_ips(ips, IP_FLAGS)
    from trossen_arm_mujoco.twin.served_kit import check_kit_ips
    from trossen_arm_mujoco.twin.serving import require_sim_server

    ips = check_kit_ips(ips, IP_FLAGS)
    if not args.dry_run:
        require_sim_server()
    return ips


def find_episode(folder: Path, index: int) -> Path:
    """The file of episode ``index`` in ``folder``; a missing one is a one-line error that
    names the flags choosing it and the episodes that are there."""
    path = episode_path(folder, index)
    if path.is_file():
        return path
    if not folder.is_dir():
        raise UserError(
            f"data folder not found: {folder}; check --data_dir (relative to --root_dir "
            f"unless absolute)"
        )
    found = [k for k, _ in list_episodes(folder)]
    if not found:
        raise UserError(f"{folder} holds no episode files (episode_<k>.hdf5); check --data_dir")
    raise UserError(
        f"episode file not found: {path}; {folder} holds {format_indices(found)}: pass one "
        f"of them with --episode_idx"
    )


def output_dir(args: argparse.Namespace, episode: Episode) -> Path:
    """``--output_dir`` (``~`` expanded), else ``replay/`` next to the episode."""
    if args.output_dir is None:
        return episode.path.parent / "replay"
    return Path(args.output_dir).expanduser()


def end_effector_note(name: str, backend: str, dry_run: bool) -> str | None:
    """Check ``--end_effector`` against the installed trossen_arm; returns a note or None.

    Args:
        name: the preset name given.
        backend: ``--backend`` (``sim``, ``trossen``, ``wire``).
        dry_run: ``--dry_run`` (nothing connects: a missing trossen_arm is a note).

    Raises:
        UserError: an unknown preset (listing the valid ones), or the trossen backend
            without trossen_arm (install hint).
    """
    ta = find_trossen_arm()
    if ta is None:
        if backend in ("trossen", "wire") and not dry_run:
            import_trossen_arm()  # raises the install hint
        return f"note: trossen_arm is not installed, so --end_effector {name} is not checked"
    check_end_effector(ta, name)
    if backend == "sim" and name != DEFAULT_END_EFFECTOR:
        return f"note: --end_effector {name} is valid; the twin models the follower gripper"
    return None
