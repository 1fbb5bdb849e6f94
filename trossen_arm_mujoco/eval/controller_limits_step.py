"""The arm controller's limits as steps of a checkpoint's saved processors, so that every
runner of the checkpoint sends only goals the real controller accepts.

:func:`add_to_checkpoint` adds ``trossen_arm_measured_joints`` (:data:`MEASURED_NAME`) to
``policy_preprocessor.json`` and ``trossen_arm_controller_limits`` (:data:`REGISTRY_NAME`)
to ``policy_postprocessor.json``: each action is clipped into the controller's ranges
(:func:`controller_bounds`), each joint kept within :func:`joint_steps` of its measured
position and each gripper goal within :func:`gripper_rates` of the one before. Editing the
JSON needs no LeRobot; running the steps does::

    python -m trossen_arm_mujoco.eval.controller_limits_step CHECKPOINT_FOLDER

Docs: docs/cli/prepare.md, docs/train-eval.md; why: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import hashlib
import math
import secrets
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import step_names
from trossen_arm_mujoco.eval.processor_files import (
    POSTPROCESSOR_FILE,
    PREPROCESSOR_FILE,
    SavedProcessors,
    place_step,
    read_json,
)
from trossen_arm_mujoco.export.dataset_settings import checkpoint_settings
from trossen_arm_mujoco.real.arm_controller import controller_target
from trossen_arm_mujoco.real.controller_checks import controller_limits
from trossen_arm_mujoco.real.goal_trajectory import GOAL_TIME_FACTOR
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX
from trossen_arm_mujoco.robot.configs import MOBILE_AI_BASE_LIMITS
from trossen_arm_mujoco.robot.lerobot_keys import ACTION_KEY

__all__ = [
    "MEASURED_NAME",
    "POSTPROCESSOR_FILE",
    "PREPROCESSOR_FILE",
    "REGISTRY_NAME",
    "GRIPPER_RATE_MARGIN",
    "SPEED_MARGIN",
    "action_size",
    "add_limits",
    "add_to_checkpoint",
    "controller_bounds",
    "gripper_rates",
    "joint_steps",
    "register",
]

#: Name of the postprocessor step in LeRobot's processor registry (and in
#: ``policy_postprocessor.json``).
REGISTRY_NAME = step_names.LIMITS
#: Name of the preprocessor step that notes the measured joints.
MEASURED_NAME = step_names.MEASURED
#: Fraction of each joint's velocity limit a goal may ask from the measured joints (the
#: driver starts from its setpoint, which leads the measured joints a little in motion).
SPEED_MARGIN = 0.75

#: The Mobile AI's layout name (``robot.layout``): 16 values that are not the vendor's 16.
MOBILEAI = "mobileai"

#: What an action of another size is told (the layouts the steps know).
_SIZE_ERROR = (
    "the actions have {size} values; the controller's limits know a single arm's 7, the "
    "kit's 14 and the vendor's or the Mobile AI's 16"
)

#: Fraction of a gripper's velocity limit its goals may change by per period (the recorded
#: grippers move at up to 0.8 of it).
GRIPPER_RATE_MARGIN = 0.9


def controller_bounds(size: int, layout: str | None = None) -> tuple[list[float], list[float]]:
    """(low, high) of each action value the controller accepts as is, for a single arm's 7
    values (6 joints rad, the gripper m), the kit's 14 (the same per arm), the vendor's 16
    (the gripper twice) or, with ``layout`` ``"mobileai"``, the Mobile AI's 16 (the kit's
    14, then the base's ``x.vel`` m/s and ``theta.vel`` rad/s within the base's limits,
    which it clips to)."""
    lims = controller_limits()
    low = [lim.position_min for lim in lims]
    high = [controller_target(lim.position_max, j, lim) for j, lim in enumerate(lims)]
    low[6], high[6] = 0.0, min(high[6], GRIPPER_MAX)
    if size == 7:
        return low, high
    if size == 14:
        return low * 2, high * 2
    if size == 16 and layout == MOBILEAI:
        base = MOBILE_AI_BASE_LIMITS
        return low * 2 + [-base.x_vel, -base.theta_vel], high * 2 + [base.x_vel, base.theta_vel]
    if size == 16:
        arm_low, arm_high = low[:6] + [low[6]] * 2, high[:6] + [high[6]] * 2
        return arm_low * 2, arm_high * 2
    raise UserError(_SIZE_ERROR.format(size=size))


def joint_steps(size: int, fps: float, layout: str | None = None) -> list[float]:
    """Largest distance (rad) of each value's goal from its measured position, per action
    at ``fps``: :data:`SPEED_MARGIN` x the joint's velocity limit x ``GOAL_TIME_FACTOR /
    fps``; 0 for the grippers and the Mobile AI's base velocities (not limited). Same
    layouts as :func:`controller_bounds`.

    Args:
        size: the number of action values (7, 14 or 16).
        fps: the checkpoint's action rate (Hz).
        layout: ``"mobileai"`` for the Mobile AI's 16 values; None: the kit's or the vendor's.
    """
    if not (math.isfinite(fps) and fps > 0):
        raise UserError(f"fps must be a positive finite number, got {fps}")
    goal_time = GOAL_TIME_FACTOR / float(fps)
    joints = [SPEED_MARGIN * lim.velocity_max * goal_time for lim in controller_limits()[:6]]
    if size in (7, 14):
        return (joints + [0.0]) * (size // 7)
    if size == 16 and layout == MOBILEAI:
        return (joints + [0.0]) * 2 + [0.0, 0.0]
    if size == 16:
        return (joints + [0.0, 0.0]) * 2
    raise UserError(_SIZE_ERROR.format(size=size))


def gripper_rates(size: int, fps: float, layout: str | None = None) -> list[float]:
    """Largest change (m) of each gripper's goal from one action to the next at ``fps``:
    :data:`GRIPPER_RATE_MARGIN` x the gripper's velocity limit / fps; 0 for every other
    value. The driver starts each goal from its setpoint, which covers a third of the way
    to the last goal in a period, so goals that change by at most ``d`` per period ask at
    most ``d * fps``: the grippers then never ask more than 0.9 of their limit, whatever the
    policy gives. Same layouts as :func:`controller_bounds`.

    Args:
        size: the number of action values (7, 14 or 16).
        fps: the checkpoint's action rate (Hz).
        layout: ``"mobileai"`` for the Mobile AI's 16 values; None: the kit's or the vendor's.
    """
    steps = joint_steps(size, fps, layout)  # checks size and fps
    rate = GRIPPER_RATE_MARGIN * controller_limits()[6].velocity_max / float(fps)
    grippers = {6, 13} if size in (7, 14) or layout == MOBILEAI else {6, 7, 14, 15}
    return [rate if i in grippers else 0.0 for i in range(len(steps))]


def action_size(folder: str | Path) -> int:
    """The number of action values of the checkpoint in ``folder`` (its ``config.json``'s
    ``output_features``); a one-line UserError when it does not say."""
    path = Path(folder) / "config.json"
    try:
        size = read_json(path)["output_features"][ACTION_KEY]["shape"][0]
    except FileNotFoundError:
        raise UserError(
            f"{Path(folder)}: no config.json there; give a LeRobot checkpoint "
            "folder (.../checkpoints/last/pretrained_model)"
        ) from None
    except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        raise UserError(
            f"{path}: no action shape in it ({type(exc).__name__}: {exc}); "
            "not a LeRobot checkpoint's config"
        ) from None
    if isinstance(size, bool) or not isinstance(size, int) or size <= 0:
        raise UserError(f"{path}: the action shape {size!r} is not a positive whole number")
    return size


def _link_of(folder: Path) -> str:
    """16 hex digits from the checkpoint's ``config.json`` (random where it cannot be read)."""
    try:
        return hashlib.sha256((Path(folder) / "config.json").read_bytes()).hexdigest()[:16]
    except OSError:
        return secrets.token_hex(8)


def add_limits(procs: SavedProcessors, size: int, fps: float | None, layout: str | None) -> None:
    """Put (or bring up to date) the two steps in ``procs`` (in memory): the range for
    ``size`` action values of ``layout``; with ``fps``, the joint steps and gripper rates
    at that rate and the measured-joints step sharing the limits step's ``link``.

    Args:
        procs: the checkpoint's saved processors, edited in memory.
        size: the number of action values (7, 14 or 16).
        fps: the checkpoint's action rate (Hz); None: the ranges only.
        layout: ``"mobileai"`` for the Mobile AI's 16 values; None: the kit's or the vendor's.
    """
    if fps is not None and not (isinstance(fps, int | float) and math.isfinite(fps) and fps > 0):
        raise UserError(
            f"the checkpoint's rate must be a positive number of frames per second, got {fps!r}"
        )
    pre_steps, post_steps = procs.pre["steps"], procs.post["steps"]
    low, high = controller_bounds(size, layout)
    config: dict[str, Any] = {"low": low, "high": high}
    old = next((s for s in post_steps if s.get("registry_name") == REGISTRY_NAME), None)
    # the token pairing the two steps: derived from the checkpoint's config, so that two
    # runs preparing one checkpoint at once write the same one into both files
    link = (old or {}).get("config", {}).get("link") or _link_of(procs.folder)
    if fps is not None:
        config.update(
            max_step=joint_steps(size, fps, layout),
            max_rate=gripper_rates(size, fps, layout),
            link=link,
        )
        measured = {"registry_name": MEASURED_NAME, "config": {"link": link}}
        place_step(pre_steps, MEASURED_NAME, measured, before="normalizer_processor")
    step = {"registry_name": REGISTRY_NAME, "config": config}
    place_step(post_steps, REGISTRY_NAME, step, after="unnormalizer_processor")


def add_to_checkpoint(folder: str | Path, fps: float | None = None) -> bool:
    """Add (or bring up to date) the two steps in the checkpoint's saved processors, both
    files or neither; False when they are there already as they would be written. The
    action size comes from the checkpoint's ``config.json``, the rate from ``fps``, else the
    checkpoint's settings (``export.dataset_settings.checkpoint_settings``: its
    ``trossen_settings.json`` or its training dataset's metadata; without any, only the
    range is clipped)."""
    size = action_size(folder)
    procs = SavedProcessors.load(folder)
    settings, _ = checkpoint_settings(folder)  # its own, else its dataset's
    if fps is None and settings is not None:
        fps = float(settings.fps)
    add_limits(procs, size, fps, None if settings is None else settings.layout)
    return procs.save()


def register() -> None:
    """Register both steps with LeRobot's processor registry (needs LeRobot; importing
    ``eval.steps`` does it, once a process)."""
    import trossen_arm_mujoco.eval.steps  # noqa: F401


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m trossen_arm_mujoco.eval.controller_limits_step FOLDER ...``."""
    folders = list(sys.argv[1:] if argv is None else argv)
    if not folders:
        print(
            "usage: python -m trossen_arm_mujoco.eval.controller_limits_step CHECKPOINT ...",
            file=sys.stderr,
        )
        return 2
    try:
        for folder in folders:
            added = add_to_checkpoint(folder)
            print(
                f"{folder}: {'added' if added else 'already has'} the steps {REGISTRY_NAME} "
                f"and {MEASURED_NAME}"
            )
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
