"""Two-phase recording of a single wxai arm's task with a scripted end-effector policy.

A policy with ``action_layout = "arm_ee"`` (``policies.scripted.ArmWaypointPolicy``: the
shipped ``push`` and ``pick_place``) gives each step one arm's tool pose and gripper, ``[xyz
(m), quat wxyz, gripper (m)]``, world frame. Phase 1 (nothing rendered): the joint flavour in
``ee_pose`` mode, its controller solving IK within the real arm's speed limits; the joint
targets applied are kept. Phase 2: they are replayed in ``joint_position`` mode from the same
scene, the cameras rendered and each step streamed to the file; success is judged at the
last step. The file (``data.schema``, ``layout = "widowxai"``) holds ``(T, 7)`` ``qpos``,
``qvel``, ``action`` (``joint_0`` .. ``joint_5`` rad, then the gripper carriage m), ``goal``
(3,) m and ``dt`` = the task's ``policy_dt``.

Docs: docs/cli/record.md (Single-arm tasks); details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.collect.pipeline import (
    EpisodeOutcome,
    RecordSettings,
    StepHook,
    episode_attrs,
    episode_seed,
    limit_speed,
    write_episode,
)
from trossen_arm_mujoco.data.schema import SCHEMA, SINGLE_ARM_LAYOUT
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.policies.scripted import ARM_EE
from trossen_arm_mujoco.real.validate import ArmLimits, TrajectoryError, validate_actions
from trossen_arm_mujoco.robot.configs import ACTUATED_FINGER, JOINT_VELOCITY_LIMITS
from trossen_arm_mujoco.robot.layout import ARM_JOINTS
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

__all__ = [
    "ARM_ACTION_SPEED_LIMITS",
    "ARM_VALUES",
    "SingleArmRecorder",
    "arm_to_vendor16",
    "is_arm_ee_policy",
]

#: The 7 recorded values of the arm: its 6 joints, then the gripper (actuated carriage).
ARM_VALUES: tuple[str, ...] = (*ARM_JOINTS, ACTUATED_FINGER)
#: Speed limit of each of the 7 values (URDF: rad/s, m/s).
ARM_ACTION_SPEED_LIMITS = np.array([JOINT_VELOCITY_LIMITS[j] for j in ARM_VALUES])


def is_arm_ee_policy(policy_cls: type) -> bool:
    """Whether a scripted policy gives one arm's tool pose (``action_layout == "arm_ee"``)."""
    return getattr(policy_cls, "action_layout", "ee") == ARM_EE


def arm_to_vendor16(actions: np.ndarray) -> np.ndarray:
    """``(T, 7)`` arm actions as ``(T, 16)`` rows of the real-replay check: the arm as the
    left arm (both finger values = the gripper), the right arm holding still at the first
    row's values."""
    a = np.asarray(actions, dtype=float)
    left = np.concatenate([a, a[:, 6:7]], axis=1)
    return np.concatenate([left, np.broadcast_to(left[:1], left.shape)], axis=1)


class SingleArmRecorder:
    """Records episodes of a single-arm task with an ``arm_ee`` scripted policy (module
    docstring).

    The same interface as ``collect.pipeline.EpisodeRecorder`` (``record``, ``close``,
    ``settings``, ``joint_scene``, ``policy_dt``, ``fps``, ``minimum_episode_len``,
    ``scripted_rollout``, ``replay``); ``max_reward`` is NaN (the task judges success).

    Args:
        settings: ``collect.pipeline.RecordSettings`` of the run.
        step_hook: called after each phase-2 step with (t, observation, joint ``Scene``).
    """

    def __init__(self, settings: RecordSettings, step_hook: StepHook | None = None):
        self.entry = registry.load(settings.task_name)
        self.policy_cls = self.entry.policy_class()
        self.settings = settings
        self.step_hook = step_hook
        self.arm_limits = ArmLimits.from_mjcf()
        self.last_speed_limited = 0
        sampler_cls = self.entry.sampler_class()
        if len(sampler_cls.arms) != 1:
            raise UserError(
                f"task '{self.entry.name}': its policy {self.policy_cls.__name__} acts on one "
                f"arm (action_layout 'arm_ee'), but its sampler has {len(sampler_cls.arms)} "
                "arms"
            )
        self.arm_group, self.gripper_group = sampler_cls.arms[0]
        # phase 1: the arm takes tool poses (IK within the joint speed limits), no cameras
        ee = SamplerSettings(command_mode="ee_pose", randomize=settings.randomize)
        self.ee_sampler = registry.make_sampler(self.entry.name, ee)
        self.joint_sampler = registry.make_sampler(self.entry.name, settings.sampler_settings())
        #: randomization record of the last episode (None: not randomizing).
        self.last_randomization: dict | None = None
        self.ee_task = None
        self.joint_task = None
        probe = self.joint_sampler.make_task()
        self.policy_dt = probe.policy_dt
        self.fps = 1.0 / self.policy_dt
        self.max_reward = float("nan")
        #: Steps the scripted policy needs to finish the task (0 when it does not say).
        self.minimum_episode_len = int(getattr(self.policy_cls, "minimum_episode_len", 0))
        self._state_index = {
            flavour: self._state_indices(sampler)
            for flavour, sampler in (("ee", self.ee_sampler), ("joint", self.joint_sampler))
        }
        arm = self.joint_sampler.robot_view.get_move_group(self.arm_group)
        gripper = self.joint_sampler.robot_view.get_move_group(self.gripper_group)
        self.action_low = np.concatenate([arm.ctrl_limits[:, 0], gripper.ctrl_limits[:, 0]])
        self.action_high = np.concatenate([arm.ctrl_limits[:, 1], gripper.ctrl_limits[:, 1]])

    def _state_indices(self, sampler) -> tuple[np.ndarray, np.ndarray]:
        """(qpos indices, dof indices) of the 7 recorded values in ``sampler``'s model."""
        view, model = sampler.robot_view, sampler.scene.model
        arm = view.get_move_group(self.arm_group)
        gripper = view.get_move_group(self.gripper_group)
        finger = int(model.actuator_trnid[gripper.actuator_id, 0])
        qpos = np.array([*arm.qpos_idx, model.jnt_qposadr[finger]], dtype=int)
        dofs = np.array([*arm.dof_idx, model.jnt_dofadr[finger]], dtype=int)
        return qpos, dofs

    @property
    def joint_scene(self):
        """The recorded world (``sim.scene.Scene``)."""
        return self.joint_sampler.scene

    def policy_observation(self, task) -> dict[str, np.ndarray]:
        """What the policy is called with: the task's observation, ``ee_pose`` (7,) the
        tool frame [xyz m, quat wxyz] (world), ``env_state`` (7 per object) and ``goal``
        (3,) m for a goal-conditioned task."""
        scene = task.scene
        obs = dict(task.get_observation())
        arm = task.robot.view.get_move_group(self.arm_group)
        obs["ee_pose"] = arm.get_frame_pose(scene.data)
        obs["env_state"] = self._env_state(scene)
        if getattr(task, "goal_conditioned", False):
            obs["goal"] = np.array(task.goal, dtype=float)
        return obs

    @staticmethod
    def _env_state(scene) -> np.ndarray:
        """Poses of the scene's objects, 7 each ([xyz m, quat wxyz]), in ``objects`` order."""
        poses = [obj.get_pose(scene.data) for obj in scene.objects.values()]
        return np.concatenate(poses) if poses else np.zeros(0)

    def _start(self, sampler, seed: int):
        """The episode of ``seed`` in ``sampler`` (the same draws in both flavours)."""
        return sampler.next_task(np.random.default_rng(seed))

    def scripted_rollout(
        self,
        seed: int | np.random.Generator,
        object_poses: dict[str, np.ndarray] | None = None,
        goal: np.ndarray | None = None,
    ) -> tuple[np.ndarray, dict]:
        """Phase 1. Returns (joint actions (T, 7), initial object poses {name: (7,)}).

        Args:
            seed: the episode's seed, or its generator (``eval``'s episode stream).
            object_poses: object name -> pose (7,) [xyz m, quat wxyz] replacing the sampled
                ones (``eval --policy scripted`` plans the eval env's episode).
            goal: (3,) goal (m, world frame) replacing the sampled one.

        The actions are the joint targets the ``ee_pose`` controller applied (within the joint
        limits and the real arm's speed limits at the recording rate); any value still faster
        is rate-limited (``self.last_speed_limited`` counts them; normally 0). They are rounded
        to the file's dtype (float32), so phase 2 replays exactly the stored values.
        """
        s = self.settings
        rng = np.random.default_rng(seed)
        task = self.ee_task = self.ee_sampler.next_task(rng, object_poses=object_poses)
        if goal is not None:
            task.goal = goal
        self.last_randomization = self.ee_sampler.randomization
        scene = self.ee_sampler.scene
        poses = {name: obj.get_pose(scene.data) for name, obj in scene.objects.items()}
        policy = self.policy_cls(inject_noise=s.inject_noise, rng=rng)
        arm = task.robot.view.get_move_group(self.arm_group)
        gripper = task.robot.view.get_move_group(self.gripper_group)
        actions = np.empty((s.episode_len, len(ARM_VALUES)))
        for t in range(s.episode_len):
            ee = np.asarray(policy(self.policy_observation(task)), dtype=float)
            if ee.shape != (8,):
                raise UserError(
                    f"policy {self.policy_cls.__name__}: an arm_ee action has 8 values "
                    f"[xyz, quat wxyz, gripper], got shape {ee.shape}"
                )
            task.step({self.arm_group: ee[:7], self.gripper_group: ee[7:8]})
            actions[t, :6] = arm.get_ctrl(scene.data)
            actions[t, 6] = gripper.get_ctrl(scene.data)[0]
        np.clip(actions, self.action_low, self.action_high, out=actions)
        self.last_speed_limited = limit_speed(actions, ARM_ACTION_SPEED_LIMITS, self.fps)
        actions[:] = actions.astype(SCHEMA.array("action").dtype)
        return actions, poses

    def scripted_success(self) -> bool:
        """Whether phase 1 ended in success (the task's judgement)."""
        return self.ee_task is not None and bool(self.ee_task.judge_success())

    def replay(
        self,
        actions: np.ndarray,
        seed: int,
        writer: EpisodeWriter | None = None,
        progress: Callable[[], None] | None = None,
    ) -> np.ndarray:
        """Phase 2: replay joint actions in the episode of ``seed``. Each step appends (state
        before the action, action, reward after it) to ``writer``.

        Args:
            actions: ``(T, 7)`` joint actions (rad; gripper m).
            seed: the episode's seed (the same scene as phase 1).
            writer: where each step goes; None: nothing is written.
            progress: called after every step.

        Returns:
            ``(T,)`` rewards.
        """
        rewards = np.empty(len(actions))
        for _ in self.replay_steps(actions, seed, rewards, writer):
            if progress is not None:
                progress()
        return rewards

    def replay_steps(
        self,
        actions: np.ndarray,
        seed: int,
        rewards: np.ndarray,
        writer: EpisodeWriter | None = None,
    ) -> Iterator[int]:
        """:meth:`replay`, one step per iteration: yields ``t`` after step ``t``.

        Args:
            actions: ``(T, 7)`` joint actions (rad; gripper m).
            seed: the episode's seed.
            rewards: ``(T,)`` array that receives the rewards.
            writer: where each step goes; None: nothing is written.
        """
        task = self.joint_task = self._start(self.joint_sampler, seed)
        scene = self.joint_sampler.scene
        data = scene.data
        qpos_idx, dof_idx = self._state_index["joint"]
        for t in range(len(actions)):
            images = scene.render_images() if writer is not None else {}
            qpos, qvel = data.qpos[qpos_idx].copy(), data.qvel[dof_idx].copy()
            env_state = self._env_state(scene)
            a = actions[t]
            task.step({self.arm_group: a[:6], self.gripper_group: a[6:7]})
            rewards[t] = task.get_reward()
            if writer is not None:
                writer.append(
                    qpos=qpos,
                    qvel=qvel,
                    action=a,
                    reward=rewards[t],
                    env_state=env_state,
                    images=images,
                )
            if self.step_hook is not None:
                self.step_hook(t, task.get_observation(), scene)
            yield t

    def record(
        self,
        attempt: int,
        path: Path,
        overwrite: bool = False,
        progress: Callable[[], None] | None = None,
        extra_attrs: dict | None = None,
        create_folder: bool = True,
    ) -> EpisodeOutcome:
        """Record attempt ``attempt`` into ``path``.

        Args:
            attempt: the attempt number; the seed derives from the run seed and it.
            path: the episode file to write.
            overwrite: replace a file already at ``path``.
            progress: called after every recorded step (a progress bar).
            extra_attrs: root attributes added to the file.
            create_folder: create ``path``'s folder if missing; False: it must exist (a
                dataset run: a folder removed meanwhile is an ``EpisodeIOError``, not
                silently recreated).

        Returns:
            The :class:`EpisodeOutcome`.
        """
        s = self.settings
        seed = episode_seed(s.base_seed, attempt)
        actions, poses = self.scripted_rollout(seed)
        speed_ok, peak_use = self.check_real_replay(actions)
        goal = getattr(self.ee_task, "goal", None)
        attrs = episode_attrs(
            s,
            self.entry.name,
            attempt,
            self.policy_dt,
            poses,
            self.last_randomization,
            extra_attrs,
            layout=SINGLE_ARM_LAYOUT,
            joint_names=list(ARM_VALUES),
            **({"goal": np.asarray(goal, dtype=float)} if goal is not None else {}),
            real_replay_checked=speed_ok,
            peak_speed_fraction=peak_use,
            speed_limited_values=int(self.last_speed_limited),
        )

        def play(writer: EpisodeWriter) -> tuple[np.ndarray, bool, dict]:
            return self.replay(actions, seed, writer, progress), speed_ok, {}

        def judge() -> bool:
            return bool(self.joint_task.judge_success())

        return write_episode(
            s, path, attrs, play, self.max_reward, overwrite, create_folder, judge=judge
        )

    def check_real_replay(self, actions: np.ndarray) -> tuple[bool, float]:
        """The 7 values through the real-replay validator at the recording rate (1 /
        policy_dt), as one arm of ``replay_episode_real.py --fps 50 --dry_run``. Returns
        (passed, largest speed as a fraction of its limit; NaN when the check failed)."""
        try:
            trajectory = validate_actions(arm_to_vendor16(actions), self.fps, self.arm_limits)
        except TrajectoryError:
            return False, float("nan")
        return True, float(np.max(trajectory.peak_speed / self.arm_limits.velocity))

    def close(self) -> None:
        """Close both samplers and the envs (and renderers) they own."""
        self.ee_sampler.close()
        self.joint_sampler.close()
