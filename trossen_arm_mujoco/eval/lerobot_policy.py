"""A LeRobot ``PreTrainedPolicy`` checkpoint (ACT, diffusion, ...) driving a ``KitPolicyEnv``.

The checkpoint folder is what ``lerobot-train`` saves (``.../checkpoints/last/
pretrained_model``, or the ``checkpoints/<step>`` folder above it). The policy's input
features are held against the env's before anything runs (a mismatch is one line); each step
runs LeRobot's own path: ``preprocess_observation``, the saved preprocessor,
``select_action``, the saved postprocessor. LeRobot (Python >= 3.12) is imported only here.

Docs: docs/cli/eval.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.camera_pose_step import camera_of
from trossen_arm_mujoco.eval.env import KitPolicyEnv, feature_spec
from trossen_arm_mujoco.robot.lerobot_keys import (
    ACTION_KEY,
    ENV_STATE_KEY,
    image_camera,
    image_key,
)

__all__ = [
    "ENV_STATE_KEY",
    "LEROBOT_MISSING",
    "LeRobotPolicy",
    "check_checkpoint",
    "check_loadable",
    "checkpoint_dir",
    "checkpoint_features",
    "feature_mismatch",
    "import_lerobot",
]

LEROBOT_MISSING = (
    "evaluating a LeRobot checkpoint needs LeRobot 0.6 (Python >= 3.12): "
    "pip install 'trossen-arm-mujoco[train]'"
)


def import_lerobot() -> Any:
    """The ``lerobot`` package, or a one-line UserError saying how to install it."""
    try:
        import lerobot  # noqa: F401
        from lerobot.configs.policies import PreTrainedConfig  # noqa: F401
    except ImportError:
        raise UserError(LEROBOT_MISSING) from None
    import lerobot

    return lerobot


def checkpoint_dir(path: str | Path) -> Path:
    """The folder holding the checkpoint's ``config.json`` (``path`` or its
    ``pretrained_model``); a one-line UserError when there is none."""
    p = Path(path).expanduser()
    for candidate in (p, p / "pretrained_model"):
        if (candidate / "config.json").is_file():
            return candidate
    if not p.exists():
        raise UserError(
            f"--policy {path}: no such checkpoint folder; give the "
            "pretrained_model folder lerobot-train saved, 'scripted' or "
            "module:function"
        )
    raise UserError(
        f"--policy {path} holds no LeRobot checkpoint (no config.json in it or in "
        "its pretrained_model folder)"
    )


def checkpoint_features(path: str | Path) -> dict[str, Any]:
    """What a checkpoint's ``config.json`` says it observes, read without LeRobot: its
    cameras (``cam_names``), their (H, W) (``image_size``), the layout name of its action
    (``layout``: ``kit14`` for 14 values, ``vendor16`` for 16, ``widowxai`` for 7), and
    whether it observes what no real kit can give (``sim_only``:
    ``observation.environment_state``, the objects' exact poses, unless the checkpoint's
    preprocessor computes them from a camera: ``eval.camera_pose_step``). Keys are missing
    when the config does not say."""
    folder = checkpoint_dir(path)
    try:
        config = json.loads((folder / "config.json").read_text(encoding="utf-8"))
        inputs = dict(config.get("input_features") or {})
        outputs = dict(config.get("output_features") or {})
    except (OSError, ValueError, AttributeError, TypeError) as exc:
        raise UserError(f"--policy {path}: cannot read its config.json ({exc})") from None
    found: dict[str, Any] = {}
    cams = [cam for cam in map(image_camera, inputs) if cam is not None]
    found["cam_names"] = tuple(cams)
    if cams:
        shape = inputs[image_key(cams[0])].get("shape") or []
        if len(shape) == 3:
            found["image_size"] = (int(shape[1]), int(shape[2]))
    # what only the simulation has, unless the checkpoint's own pose encoder computes it
    # from a camera (eval.camera_pose_step): then that camera is what it observes
    pose_camera = camera_of(folder)
    found["sim_only"] = ENV_STATE_KEY in inputs and pose_camera is None
    if pose_camera is not None:
        found["pose_camera"] = pose_camera
        if pose_camera not in cams:
            found["cam_names"] = (*cams, pose_camera)
    size = (outputs.get(ACTION_KEY) or {}).get("shape") or []
    if list(size) == [14]:
        found["layout"] = "kit14"
    elif list(size) == [16]:
        found["layout"] = "vendor16"
    elif list(size) == [7]:  # one WidowX AI arm (eval.arm_env)
        found["layout"] = "widowxai"
    return found


def check_checkpoint(path: str | Path, env: KitPolicyEnv) -> None:
    """Refuse, in one line, a checkpoint whose ``config.json`` features ``env`` cannot
    serve (read without LeRobot; ``LeRobotPolicy`` checks again with LeRobot's config)."""
    folder = checkpoint_dir(path)
    try:
        config = json.loads((folder / "config.json").read_text(encoding="utf-8"))
        inputs = {k: tuple(v["shape"]) for k, v in (config.get("input_features") or {}).items()}
        action = ((config.get("output_features") or {}).get(ACTION_KEY) or {}).get("shape")
    except (OSError, ValueError, AttributeError, TypeError, KeyError) as exc:
        raise UserError(f"--policy {path}: cannot read its config.json ({exc})") from None
    _raise_on_mismatch(path, inputs, action, env)


def _raise_on_mismatch(
    path: str | Path, inputs: dict[str, tuple[int, ...]], action: Any, env: KitPolicyEnv
) -> None:
    problems = feature_mismatch(inputs, env)
    if action is not None and tuple(action) != (env.layout.size,):
        problems.append(
            f"action {list(action)} (the env takes {env.layout.size} values, "
            f"layout {env.layout_name})"
        )
    if problems:
        raise UserError(
            f"--policy {path} was trained on other features than this env offers: "
            + "; ".join(problems)
            + " (match --cam_names, --image_size, --layout and the task to its dataset)"
        )


def feature_mismatch(policy_inputs: dict[str, tuple[int, ...]], env: KitPolicyEnv) -> list[str]:
    """Differences between a policy's input features (LeRobot key -> shape; images (C,H,W))
    and what ``env`` observes; empty when the policy can run on it."""
    offered: dict[str, tuple[int, ...]] = {}
    features = getattr(env, "features", None)  # a single arm's env says its own
    spec = (
        features()
        if callable(features)
        else feature_spec(env.task_name, env.cam_names, env.image_size, env.layout_name)
    )
    for key, kind, shape in spec.values():
        if kind == "VISUAL":
            shape = (shape[2], shape[0], shape[1])
        if kind != "ACTION":
            offered[key] = tuple(shape)
    problems = []
    for key, shape in policy_inputs.items():
        if key not in offered:
            problems.append(f"{key} {list(shape)} (not observed by this env)")
        elif offered[key] != tuple(shape):
            problems.append(f"{key} {list(shape)} (the env gives {list(offered[key])})")
    return problems


def _register_steps() -> None:
    """Register this project's processor steps with LeRobot (a checkpoint's postprocessor
    may hold the controller's limits, its preprocessor a pose encoder)."""
    from trossen_arm_mujoco.eval.camera_pose_step import register as register_camera_pose
    from trossen_arm_mujoco.eval.controller_limits_step import register

    register()
    register_camera_pose()


def check_loadable(path: str | Path) -> None:
    """Refuse, in one line naming the file, a checkpoint LeRobot could not load: its weights
    or processor files missing or damaged (``eval.checkpoint_files``), or a saved processor
    step this LeRobot does not know. Reads file headers only: no model is built."""
    import importlib

    from trossen_arm_mujoco.eval.checkpoint_files import check_checkpoint_files, saved_steps

    folder = checkpoint_dir(path)
    check_checkpoint_files(folder, path)
    import_lerobot()
    from lerobot.processor import ProcessorStepRegistry

    _register_steps()
    for name, i, step in saved_steps(folder):
        where = f"--policy {path}: step {i} of {folder / name}"
        if "registry_name" in step:
            try:
                ProcessorStepRegistry.get(step["registry_name"])
            except KeyError:
                raise UserError(
                    f"{where} is '{step['registry_name']}', a processor step this LeRobot "
                    f"does not know (LeRobot {_lerobot_version()}): evaluate where the "
                    "package that registers it is installed, or train again"
                ) from None
            continue
        module, _, cls = str(step["class"]).rpartition(".")
        try:
            getattr(importlib.import_module(module), cls)
        except Exception as exc:  # ImportError, AttributeError, ValueError (no module)
            raise UserError(
                f"{where} is the class '{step['class']}', which cannot be imported "
                f"({type(exc).__name__}: {exc}): install the package that has it, or train "
                "again"
            ) from None


def _lerobot_version() -> str:
    import lerobot

    return str(getattr(lerobot, "__version__", "?"))


class LeRobotPolicy:
    """A checkpoint loaded for one env (see the module docstring).

    Args:
        path: the checkpoint folder (``.../pretrained_model`` or ``checkpoints/<step>``).
        env: the env it drives; its features are checked against the policy's.
        device: torch device (``"cpu"``, ``"cuda"``).
    """

    def __init__(self, path: str | Path, env: KitPolicyEnv, device: str = "cpu"):
        import_lerobot()
        import torch
        from lerobot.configs.policies import PreTrainedConfig
        from lerobot.envs.utils import preprocess_observation
        from lerobot.policies.factory import get_policy_class, make_pre_post_processors

        folder = checkpoint_dir(path)
        try:
            cfg = PreTrainedConfig.from_pretrained(str(folder))
        except Exception as exc:  # a corrupt or foreign config.json
            raise UserError(f"--policy {path}: cannot read its config.json ({exc})") from None
        cfg.pretrained_path = str(folder)
        cfg.device = device
        inputs = {k: tuple(f.shape) for k, f in cfg.input_features.items()}
        out = cfg.output_features.get(ACTION_KEY)
        _raise_on_mismatch(path, inputs, None if out is None else out.shape, env)
        self.torch = torch
        check_loadable(path)  # its files whole, its processor steps known (registered)
        try:
            self.policy = get_policy_class(cfg.type).from_pretrained(str(folder), config=cfg)
            self.policy.eval()
            self.pre, self.post = make_pre_post_processors(
                cfg,
                pretrained_path=str(folder),
                preprocessor_overrides={"device_processor": {"device": device}},
            )
        except (UserError, MemoryError):
            raise
        except Exception as exc:  # what the file checks cannot see (a tensor of other shape)
            why = " ".join(str(exc).split())[:300]
            raise UserError(
                f"--policy {path}: LeRobot cannot load the checkpoint in {folder} "
                f"({type(exc).__name__}: {why}); copy it again or train again"
            ) from None
        self._preprocess_observation = preprocess_observation
        self.task_text = env.task_description

    def reset(self, env: KitPolicyEnv, seed: int) -> None:
        """Start an episode of ``env``: clear the policy's action queue and the processors'
        state, and take the task's description as the language instruction (``seed`` is
        unused: the policy is deterministic)."""
        self.policy.reset()
        self.pre.reset()  # the controller-limit steps start again from the measured joints
        self.post.reset()
        self.task_text = env.task_description

    def act(self, observation: dict[str, Any]) -> np.ndarray:
        """The action for one observation: (action dim,) floats in the layout the
        checkpoint was trained on (the kit's 14 values: rad, gripper carriages m)."""
        obs = self._preprocess_observation(observation)
        obs["task"] = [self.task_text]
        obs = self.pre(obs)
        with self.torch.inference_mode():
            action = self.policy.select_action(obs)
        action = self.post(action)
        return action.to("cpu").numpy().reshape(-1).astype(float)

    def close(self) -> None:
        """Nothing to release (the model stays loaded until the object goes)."""
        pass
