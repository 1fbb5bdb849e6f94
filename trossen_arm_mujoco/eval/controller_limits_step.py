"""The arm controller's position limits as a step of a checkpoint's saved postprocessor, so
that every runner of the checkpoint sends only goals the real controller accepts.

A learned policy's actions scatter around its training targets: around a gripper closed to
2 mm on the cube it asks for -1.1 mm now and then, which the real controller refuses (its
position check allows 1 mm below the range) and the arm stops in its error state. The fix
travels with the checkpoint: :func:`add_to_checkpoint` adds the step
``trossen_arm_controller_limits`` (:data:`REGISTRY_NAME`) to the checkpoint's
``policy_postprocessor.json``, after the unnormalizer, with the limits of the checkpoint's
layout (:func:`controller_bounds`: each joint's range, each gripper 0 .. ``GRIPPER_MAX``,
0.04 m, what the controller executes anyway). LeRobot's tools (``lerobot-eval``,
``lerobot-rollout`` with Trossen's ``bi_widowxai_follower_robot``, ``lerobot-record``) load
it wherever the env plugin ``lerobot_env_trossen`` is installed (LeRobot imports every
``lerobot_env_*`` package at start, which registers the step); ``trossen-mujoco eval``
registers it itself (:func:`register`). The step clips; it does not limit speed (a jump
inside the range still faults, as on the real arm).

Editing the JSON needs no LeRobot (:func:`add_to_checkpoint`); running the step does::

    python -m trossen_arm_mujoco.eval.controller_limits_step CHECKPOINT_FOLDER
"""

from __future__ import annotations

import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.fileio import atomic_path
from trossen_arm_mujoco.real.arm_controller import controller_target
from trossen_arm_mujoco.real.controller_checks import controller_limits
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX
from trossen_arm_mujoco.robot.lerobot_keys import ACTION_KEY

__all__ = ["POSTPROCESSOR_FILE", "REGISTRY_NAME", "add_to_checkpoint", "controller_bounds",
           "register"]  # fmt: skip

#: Name of the step in LeRobot's processor registry (and in ``policy_postprocessor.json``).
REGISTRY_NAME = "trossen_arm_controller_limits"
#: The saved postprocessor of a LeRobot checkpoint.
POSTPROCESSOR_FILE = "policy_postprocessor.json"


def controller_bounds(size: int) -> tuple[list[float], list[float]]:
    """(low, high) of each action value the controller accepts as is, for the kit's 14
    values (per arm: 6 joints rad, the gripper m) or the vendor's 16 (the gripper twice)."""
    lims = controller_limits()
    low = [lim.position_min for lim in lims]
    high = [controller_target(lim.position_max, j, lim) for j, lim in enumerate(lims)]
    low[6], high[6] = 0.0, min(high[6], GRIPPER_MAX)
    if size == 14:
        return low * 2, high * 2
    if size == 16:
        arm_low, arm_high = low[:6] + [low[6]] * 2, high[:6] + [high[6]] * 2
        return arm_low * 2, arm_high * 2
    raise UserError(f"the kit's actions have 14 or 16 values, not {size}")


def add_to_checkpoint(folder: str | Path) -> bool:
    """Add the step to the checkpoint's ``policy_postprocessor.json`` (after its
    unnormalizer); False when it is there already. The action size comes from the
    checkpoint's ``config.json``."""
    folder = Path(folder)
    post, config = folder / POSTPROCESSOR_FILE, folder / "config.json"
    try:
        pipeline = json.loads(post.read_text(encoding="utf-8"))
        action = json.loads(config.read_text(encoding="utf-8"))["output_features"][ACTION_KEY]
        size = int(action["shape"][0])
        steps: list[dict[str, Any]] = pipeline["steps"]
    except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        raise UserError(f"{folder}: not a LeRobot checkpoint with a saved postprocessor "
                        f"({exc})") from None  # fmt: skip
    if any(step.get("registry_name") == REGISTRY_NAME for step in steps):
        return False
    low, high = controller_bounds(size)
    at = next((i + 1 for i, s in enumerate(steps)
               if s.get("registry_name") == "unnormalizer_processor"), len(steps))  # fmt: skip
    steps.insert(at, {"registry_name": REGISTRY_NAME, "config": {"low": low, "high": high}})
    with atomic_path(post) as tmp:
        Path(tmp).write_text(json.dumps(pipeline, indent=2) + "\n", encoding="utf-8")
    return True


def register() -> None:
    """Register the step with LeRobot's processor registry (needs LeRobot; twice is fine)."""
    from dataclasses import dataclass, field

    import torch
    from lerobot.processor import ProcessorStepRegistry
    from lerobot.processor.pipeline import ActionProcessorStep

    if REGISTRY_NAME in ProcessorStepRegistry.list():
        return

    @ProcessorStepRegistry.register(REGISTRY_NAME)
    @dataclass
    class ControllerLimitsStep(ActionProcessorStep):
        """Clip each action value into [low, high] (the arm controller's accepted range)."""

        low: list[float] = field(default_factory=list)
        high: list[float] = field(default_factory=list)

        def action(self, action):
            low = torch.as_tensor(self.low, dtype=action.dtype, device=action.device)
            high = torch.as_tensor(self.high, dtype=action.dtype, device=action.device)
            return torch.clamp(action, low, high)

        def get_config(self) -> dict[str, Any]:
            return {"low": list(self.low), "high": list(self.high)}

        def transform_features(self, features):
            return features


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m trossen_arm_mujoco.eval.controller_limits_step FOLDER ...``."""
    folders = list(sys.argv[1:] if argv is None else argv)
    if not folders:
        print("usage: python -m trossen_arm_mujoco.eval.controller_limits_step CHECKPOINT ...",
              file=sys.stderr)  # fmt: skip
        return 2
    try:
        for folder in folders:
            added = add_to_checkpoint(folder)
            print(f"{folder}: {'added' if added else 'already has'} the step {REGISTRY_NAME}")
    except UserError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
