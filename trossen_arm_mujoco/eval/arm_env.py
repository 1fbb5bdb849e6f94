"""ArmPolicyEnv: a single WidowX AI arm's task (``push``, ``pick_place``, ``reach``) in the
joint flavour, observed and acted on in the arm's 7-value layout (``widowxai``).

The single arm's counterpart of ``eval.env.KitPolicyEnv``, with the same interface: the
observation's ``agent_pos`` and ``velocity`` are (7,) (``joint_0`` .. ``joint_5`` rad, the
gripper's carriage travel m), ``environment_state`` the object poses (xyz m + quat wxyz,
world; a goal-conditioned task's goal (3,) m after them, and also as ``goal``) and
``pixels`` the cameras; the action is the 7 joint goals, sent as Trossen's
``widowxai_follower_robot`` sends them, through the real arm controller's checks (a refused
setpoint ends the episode, failed).

Docs: docs/cli/eval.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import gymnasium
import numpy as np

from trossen_arm_mujoco.clip import clip
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.eval.arm_tasks import (
    ARM_LAYOUT,
    ARM_LAYOUT_NAME,
    arm_feature_spec,
    arm_names,
    is_arm_task,
)
from trossen_arm_mujoco.eval.env import (
    _cameras,
    controller_timing,
    episode_generator,
    episode_length_of,
)
from trossen_arm_mujoco.gym.inputs import reset_options
from trossen_arm_mujoco.real.arm_controller import ARM_SIDES, GOAL_TIME_FACTOR, KitController
from trossen_arm_mujoco.sim.camera_settings import CameraSettings
from trossen_arm_mujoco.sim.cameras import CameraSet
from trossen_arm_mujoco.sim.closing import close_at_exit, forget
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.randomization_schema import RANDOMIZATION_KEY
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

__all__ = ["ARM_RENDER_CAMERA", "ArmPolicyEnv"]

#: Camera rendered for videos when the policy observes none.
ARM_RENDER_CAMERA = "overview"


class ArmPolicyEnv(gymnasium.Env):
    """A policy's view of a single arm's task (see the module docstring).

    Args:
        task_name: a single-arm task's registered name (or alias).
        cameras: what the cameras observe (``sim.camera_settings.CameraSettings``: names,
            (H, W) pixels, crops); default none (state only).
        fps: policy rate (Hz); default the task's own.
        episode_length: steps per episode; default the task's recording length at ``fps``.
        layout: only ``widowxai`` (7 values: ``joint_0`` .. ``joint_5`` rad, gripper m).
        render_mode: ``rgb_array`` (``render()`` without observed cameras shows
            ``overview`` at 240x320) or None.
        controller_checks: apply the real arm controller's checks to every setpoint (a
            fault ends the episode, failed); False: the unconstrained score.
        cam_names: the cameras as the command line gives them; not with ``cameras``.
        image_size: (H, W) or ``"HxW"`` as the command line gives it; not with ``cameras``.
        crops: ``--crop`` texts; not with ``cameras``.
        randomize: each episode's scene randomized as the task's ``randomization`` section
            says, from the episode's seed.
        randomization: a ``randomization`` section replacing the task's; implies
            ``randomize``.

    Attributes: those of ``KitPolicyEnv`` (``task_name``, ``cameras``, ``task_description``:
    the running episode's, which names its goal, ``episode_length``, ``task``: the running
    ``Task``, ``scene``, ``controller``: a one-arm ``KitController`` whose
    values are labelled ``joint_0`` .. ``gripper``, ``layout``, ``layout_name``, ``fps``).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}
    #: one arm (``eval.rollout_analysis`` reads its one gripper)
    arms = 1

    def __init__(
        self,
        task_name: str = registry.DEFAULT_ARM_TASK,
        *,
        cameras: CameraSettings | None = None,
        fps: float | None = None,
        episode_length: int | None = None,
        layout: str = ARM_LAYOUT_NAME,
        render_mode: str | None = "rgb_array",
        controller_checks: bool = True,
        cam_names: Any = None,
        image_size: Any = None,
        crops: Any = None,
        randomize: bool = False,
        randomization: Mapping[str, Any] | None = None,
    ):
        entry = registry.load(task_name)
        if not is_arm_task(entry.name):
            raise UserError(
                f"task '{entry.name}' is not a single-arm task; valid: {', '.join(arm_names())}"
            )
        if layout != ARM_LAYOUT_NAME:
            raise UserError(
                f"task '{entry.name}' takes the layout {ARM_LAYOUT_NAME} (one arm's 7 values), "
                f"not {layout!r} (--layout)"
            )
        self.layout, self.layout_name = ARM_LAYOUT, ARM_LAYOUT_NAME
        if render_mode not in (None, "rgb_array"):
            raise unknown_name_error("render mode", str(render_mode), ["rgb_array"])
        self.render_mode = render_mode
        self.cameras = _cameras(cameras, cam_names, image_size, crops)
        config = entry.load_config()
        native = 1.0 / float(config["policy_dt"])
        self.fps = float(native if fps is None else fps)
        overrides: dict[str, Any] = dict(controller_timing(self.fps))
        self.randomize = bool(randomize) or randomization is not None
        if randomization is not None:
            overrides[RANDOMIZATION_KEY] = dict(randomization)
        episode_length = episode_length_of(entry, config, self.fps, native, episode_length)
        self.task_name = entry.name
        cams = self.cameras
        settings = SamplerSettings(
            camera_names=cams.names,
            height=cams.size[0],
            width=cams.size[1],
            looks=cams.scene_looks(),
            randomize=self.randomize,
        )
        self.sampler = registry.make_sampler(entry.name, settings, **overrides)
        self.scene = self.sampler.scene
        self.arm_group, self.gripper_group = self.sampler.arms[0]
        probe = self.sampler.make_task()
        self.task_description = probe.get_task_description()
        self.episode_length = int(episode_length)
        self.metadata = {**self.metadata, "render_fps": self.fps}
        view, model = self.sampler.robot_view, self.scene.model
        arm, gripper = view.get_move_group(self.arm_group), view.get_move_group(self.gripper_group)
        finger = int(model.actuator_trnid[gripper.actuator_id, 0])
        self._qpos_idx = np.array([*arm.qpos_idx, model.jnt_qposadr[finger]], dtype=int)
        self._dof_idx = np.array([*arm.dof_idx, model.jnt_dofadr[finger]], dtype=int)
        self.action_low = np.concatenate([arm.joint_range[:, 0], gripper.ctrl_limits[:, 0]])
        self.action_high = np.concatenate([arm.joint_range[:, 1], gripper.ctrl_limits[:, 1]])
        self.action_space = gymnasium.spaces.Box(
            self.action_low.astype(np.float32), self.action_high.astype(np.float32)
        )
        self.n_objects = len(self.scene.objects)
        self._goal_conditioned = bool(getattr(probe, "goal_conditioned", False))
        self.observation_space = self._observation_space(probe)
        self._vector_bounds = {
            key: (self.observation_space[key].low, self.observation_space[key].high)
            for key in ("agent_pos", "velocity", "environment_state")
        }
        self.controller = KitController(checks=controller_checks, sides=ARM_SIDES)
        self.controller_checks = bool(controller_checks)
        self._goal_time = GOAL_TIME_FACTOR / self.fps
        self._ticks = int(probe.n_ctrl_steps)
        self._tick_dt = float(overrides["ctrl_dt"])
        self._reached = False
        self.task = None
        self.n_steps = 0
        self._images: dict[str, np.ndarray] = {}
        self._render_cams: CameraSet | None = None
        close_at_exit(self)

    @property
    def cam_names(self) -> tuple[str, ...]:
        """The observed cameras (``cameras.names``)."""
        return self.cameras.names

    @property
    def image_size(self) -> tuple[int, int]:
        """(H, W) of the observed images, pixels (``cameras.size``)."""
        return self.cameras.size

    def features(self) -> dict[str, tuple[str, str, tuple[int, ...]]]:
        """This env's LeRobot features (``arm_feature_spec``)."""
        return arm_feature_spec(
            self.n_objects, self.cam_names, self.image_size, goal=self._goal_conditioned
        )

    def _observation_space(self, probe) -> gymnasium.spaces.Dict:
        low, high = self.action_low, self.action_high
        v = float(probe.max_qvel)
        ws_low, ws_high = probe.ws_low, probe.ws_high
        pose_low = np.tile(np.concatenate([ws_low, -np.ones(4)]), self.n_objects)
        pose_high = np.tile(np.concatenate([ws_high, np.ones(4)]), self.n_objects)

        def box(lo: Any, hi: Any, n: int) -> gymnasium.spaces.Box:
            lo, hi = np.broadcast_to(lo, (n,)), np.broadcast_to(hi, (n,))
            return gymnasium.spaces.Box(lo.astype(np.float32), hi.astype(np.float32))

        size = ARM_LAYOUT.size
        if self._goal_conditioned:  # the goal after the poses, as the export writes it
            pose_low, pose_high = np.r_[pose_low, ws_low], np.r_[pose_high, ws_high]
        spaces: dict[str, gymnasium.spaces.Space] = {
            "agent_pos": box(low, high, size),
            "velocity": box(-v, v, size),
            "environment_state": box(pose_low, pose_high, len(pose_low)),
        }
        if self._goal_conditioned:
            spaces["goal"] = box(ws_low, ws_high, 3)
        if self.cam_names:
            h, w = self.image_size
            spaces["pixels"] = gymnasium.spaces.Dict(
                {
                    cam: gymnasium.spaces.Box(0, 255, (h, w, 3), dtype=np.uint8)
                    for cam in self.cam_names
                }
            )
        return gymnasium.spaces.Dict(spaces)

    # -- gymnasium API --------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode; ``seed`` picks it (``eval.env.episode_generator``); None draws
        one. ``options={"object_poses": {name: pose}}`` as ``KitPolicyEnv.reset``."""
        poses = reset_options(options, self.scene.objects)
        super().reset(seed=seed)
        if seed is None:
            seed = int(self.np_random.integers(2**31))
        self.task = self.sampler.next_task(episode_generator(seed), object_poses=poses)
        # the episode's goal in words (the language instruction a checkpoint reads)
        self.task_description = self.task.get_task_description()
        self.n_steps = 0
        self._reached = False
        obs = self._observe()
        self.controller.reset(self.scene.data.qpos[self._qpos_idx].astype(np.float64))
        info = self._info(bool(self.task.judge_success()))
        info["stage"] = float(self.task.get_reward())
        return obs, info

    def step(self, action):
        if self.task is None:
            raise UserError("call reset() before step()")
        a = np.array(action, dtype=float).reshape(-1)
        if a.shape != (ARM_LAYOUT.size,):
            raise UserError(
                f"action must have {ARM_LAYOUT.size} values (layout {ARM_LAYOUT_NAME}: "
                f"joint_0..joint_5, gripper), got shape {np.shape(action)}"
            )
        if not self.controller_checks and not np.isfinite(a).all():
            raise UserError(f"action contains NaN or inf: {np.round(a, 4).tolist()}")
        ctl, task, scene = self.controller, self.task, self.scene
        ctl.command(a, self._goal_time)
        fault = None
        for _ in range(self._ticks):
            target, fault = ctl.tick(self._tick_dt)
            if fault is not None:  # the arm stops in the error state: the episode ends
                break
            task.apply_action({self.arm_group: target[:6], self.gripper_group: target[6:7]})
            scene.step(1)
        task.finish_step()
        self.n_steps += 1
        reward = float(task.get_reward())
        success_now = bool(task.judge_success())
        self._reached = self._reached or success_now
        truncated = self.n_steps >= self.episode_length
        info = self._info(success_now, last=truncated or fault is not None)
        info["stage"] = reward
        if fault is not None:
            info["fault"] = {**fault.as_dict(), "step": self.n_steps - 1}
        return self._observe(), reward, fault is not None, truncated, info

    def render(self):
        """The observed cameras side by side (uint8 (H, n*W, 3)), or ``overview`` at
        240x320 when none is observed."""
        if self.render_mode != "rgb_array" or self.task is None:
            return None
        if self.cam_names:
            return np.concatenate([self._images[c] for c in self.cam_names], axis=1)
        if self._render_cams is None:
            self._render_cams = CameraSet(self.scene.model, [ARM_RENDER_CAMERA], 240, 320)
        return self._render_cams.render(self.scene.data, ARM_RENDER_CAMERA)

    def close(self):
        forget(self)
        if self._render_cams is not None:
            self._render_cams.close()
            self._render_cams = None
        self.sampler.close()

    @property
    def _max_episode_steps(self) -> int:
        """``episode_length`` under the name LeRobot's evaluation reads."""
        return self.episode_length

    def get_wrapper_attr(self, name: str) -> Any:
        """``task`` through a vector env is the task's name (``KitPolicyEnv.get_wrapper_attr``)."""
        return self.task_name if name == "task" else super().get_wrapper_attr(name)

    @property
    def randomization(self) -> dict[str, Any] | None:
        """What the running episode's scene was randomized by (None: the nominal scene)."""
        return self.sampler.randomization if self.randomize else None

    # -- what a policy reads --------------------------------------------------------------
    def object_poses(self) -> dict[str, np.ndarray]:
        """Object name -> current pose (7,) [xyz m, quat wxyz]."""
        data = self.scene.data
        return {name: obj.get_pose(data) for name, obj in self.scene.objects.items()}

    def goal(self) -> np.ndarray | None:
        """The episode's goal (3,) m, world (None: not a goal-conditioned task)."""
        goal = getattr(self.task, "goal", None)
        return None if goal is None else np.array(goal, dtype=float)

    def measured(self) -> np.ndarray:
        """The arm's 7 measured values now (rad; gripper m), float64."""
        return self.scene.data.qpos[self._qpos_idx].astype(np.float64)

    def _observe(self) -> dict[str, Any]:
        data = self.scene.data
        poses = list(self.object_poses().values())
        goal = self.goal()
        if goal is not None:  # environment_state ends with the goal (export.goal_state)
            poses.append(goal)
        out: dict[str, Any] = {
            "agent_pos": data.qpos[self._qpos_idx].astype(np.float32),
            "velocity": data.qvel[self._dof_idx].astype(np.float32),
            "environment_state": (np.concatenate(poses) if poses else np.zeros(0)).astype(
                np.float32
            ),
        }
        for key, (low, high) in self._vector_bounds.items():
            clip(out[key], low, high, out=out[key])
        if goal is not None:
            out["goal"] = goal.astype(np.float32)
        if self.cam_names:
            self._images = self.scene.render_images()
            out["pixels"] = self._images
        return out

    def _info(self, success_now: bool, last: bool = False) -> dict[str, Any]:
        if self.controller_checks:  # judged once the episode is over: no fault, then success
            success = last and self._reached and self.controller.fault is None
        else:
            success = success_now
        return {"is_success": bool(success), "stage": 0.0}
