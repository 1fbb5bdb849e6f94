"""The env a policy adapter sees under ``eval --backend wire`` (``eval.wire_backend``).

``eval.policies`` adapters read their env's task, rate, layout, cameras and episode length
and, for the scripted policy, the episode's object poses (and a single arm's goal).
:class:`WireEnv` gives them the in-process eval's values (from a ``KitPolicyEnv``, or a
single arm's ``ArmPolicyEnv``, that only draws scenes: reset with a seed, never stepped,
never rendered) and converts between the env's layout and the driver's values (per arm: 6
joints rad, gripper m; the kit's 14, a single arm's 7).

Docs: docs/rehearsal.md.
"""

from __future__ import annotations

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.runner import EvalSettings
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT
from trossen_arm_mujoco.sim.camera_settings import CameraSettings

__all__ = ["WireEnv", "start_fields"]


def start_fields(scenes) -> dict:
    """The served kit's ``start`` fields that show the scene ``scenes`` (a ``KitPolicyEnv``
    just reset) drew: its object poses and, when randomizing, its randomization record."""
    fields: dict = {
        "object_poses": {k: np.asarray(v).tolist() for k, v in scenes.object_poses().items()}
    }
    goal = scenes.goal() if callable(getattr(scenes, "goal", None)) else None
    if goal is not None:  # a single arm's goal-conditioned task
        fields["goal"] = np.asarray(goal, dtype=float).tolist()
    if scenes.randomization is not None:
        fields["randomization"] = scenes.randomization
    return fields


class WireEnv:
    """What a policy adapter reads of its env, for the wire: the in-process env's
    attributes (task name, rate, layout, cameras, episode length) from a ``KitPolicyEnv`` that
    only draws scenes, and the object poses sent to the kit at the last reset."""

    def __init__(self, settings: EvalSettings) -> None:
        from dataclasses import replace

        # draws scenes, never renders: no camera (the crops change no pose)
        self.scenes = replace(settings, cameras=CameraSettings()).make_env()
        s = self.scenes
        self.task_name, self.task_description, self.fps = s.task_name, s.task_description, s.fps
        self.layout, self.layout_name = s.layout, s.layout_name
        self.cameras = settings.cameras
        self.cam_names, self.image_size = self.cameras.names, self.cameras.size
        self.episode_length = s.episode_length
        self.max_reward = float(getattr(s, "max_reward", np.nan))
        self.action_low, self.action_high = s.action_low, s.action_high
        self.randomize = bool(s.randomize)
        #: one arm's 7 driver values (a single arm's task), else the kit's 14
        self.single_arm = s.layout.size == 7
        self._poses: dict[str, np.ndarray] = {}
        self._goal: np.ndarray | None = None

    def draw_scene(self, seed: int) -> dict:
        """The served kit's ``start`` fields (:func:`start_fields`) of the in-process eval's
        ``reset(seed=seed)``."""
        self.scenes.reset(seed=seed)
        self.task_description = self.scenes.task_description  # a single arm's names its goal
        self._poses = {k: np.asarray(v).copy() for k, v in self.scenes.object_poses().items()}
        goal = getattr(self.scenes, "goal", None)
        self._goal = goal() if callable(goal) else None
        return start_fields(self.scenes)

    def goal(self) -> np.ndarray | None:
        """The episode's goal (3,) m, world, of a single arm's task (None: none), a copy."""
        return None if self._goal is None else self._goal.copy()

    def object_poses(self) -> dict[str, np.ndarray]:
        """The object poses of the episode's scene: name -> (7,) world position (m) and
        quaternion (wxyz), a copy."""
        return dict(self._poses)

    def to_layout(self, values14: np.ndarray) -> np.ndarray:
        """14 driver values (a single arm's 7) -> the env's layout (float32)."""
        v = np.asarray(values14, dtype=np.float64)
        keep = self.layout is KIT14_LAYOUT or self.single_arm
        out = v if keep else KIT14_LAYOUT.to_vendor(v)
        return out.astype(np.float32)

    def to_driver(self, action: np.ndarray) -> np.ndarray:
        """An action in the env's layout -> 14 driver values (a single arm's 7), clipped to
        the joint limits."""
        a = np.array(action, dtype=np.float64).reshape(-1)
        if a.shape != (self.layout.size,) or not np.isfinite(a).all():
            raise UserError(
                f"the policy's action must be {self.layout.size} finite values "
                f"(layout {self.layout_name}), got {np.shape(action)}"
            )
        np.clip(a, self.action_low, self.action_high, out=a)
        if self.layout is KIT14_LAYOUT or self.single_arm:
            return a
        return KIT14_LAYOUT.from_vendor(a)

    def close(self) -> None:
        """Release the scene source (its physics)."""
        self.scenes.close()
