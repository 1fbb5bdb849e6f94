"""Recording of a task whose scripted policy acts in joint space (one phase).

A policy that declares ``action_layout`` (a key of ``robot.layout.LAYOUTS`` other than
``"ee"``; the Mobile AI's ``mobile_pick_place`` policy: ``"mobileai"``) gives each step's
action in that layout. The episode is recorded as it is acted: the joint flavour renders the
cameras, the policy acts on the task's observation, the scene steps, each step is streamed to
the file. The policy is made with the episode's task (``policy_cls(task, inject_noise=...,
rng=...)``) and may read its robot but never steps it. The file's root attribute ``layout``
names the rows' layout (``mobileai``: the arms' 14 values, then the base's [x.vel m/s,
theta.vel rad/s]); ``real_replay_checked``: the arms' targets and the base's commands are
within the real limits.

Docs: docs/cli/record.md, docs/concepts/models.md.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.collect.pipeline import (
    EpisodeOutcome,
    EpisodeRecorder,
    RecordSettings,
    StepHook,
    episode_attrs,
    episode_seed,
    write_episode,
)
from trossen_arm_mujoco.collect.single_arm import SingleArmRecorder, is_arm_ee_policy
from trossen_arm_mujoco.data.schema import SCHEMA
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.policies.scripted import ARM_EE
from trossen_arm_mujoco.real.validate import ArmLimits, TrajectoryError, validate_actions
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, LAYOUTS
from trossen_arm_mujoco.tasks import registry

__all__ = ["JointPolicyRecorder", "is_joint_policy", "make_recorder"]


def is_joint_policy(policy_cls: type) -> bool:
    """Whether a scripted policy acts in a joint layout (recorded in one phase); the kit's
    end-effector policies (``"ee"``) and a single arm's (``"arm_ee"``) do not."""
    return getattr(policy_cls, "action_layout", "ee") not in ("ee", ARM_EE)


def make_recorder(
    settings: RecordSettings, step_hook: StepHook | None = None
) -> EpisodeRecorder | JointPolicyRecorder | SingleArmRecorder:
    """The recorder of ``settings.task_name``: ``JointPolicyRecorder`` for a joint-space
    scripted policy, ``collect.single_arm.SingleArmRecorder`` for a single arm's end-effector
    policy (``action_layout = "arm_ee"``), else the kit's two-phase ``EpisodeRecorder``."""
    policy_cls = registry.load(settings.task_name).policy_class()
    if is_arm_ee_policy(policy_cls):
        return SingleArmRecorder(settings, step_hook)
    if is_joint_policy(policy_cls):
        return JointPolicyRecorder(settings, step_hook)
    return EpisodeRecorder(settings, step_hook)


class JointPolicyRecorder:
    """Records episodes of a task with a joint-space scripted policy (module docstring).

    The same interface as ``collect.pipeline.EpisodeRecorder`` (``record``, ``close``,
    ``settings``, ``joint_scene``, ``policy_dt``, ``fps``, ``max_reward``,
    ``minimum_episode_len``).

    Args:
        settings: ``collect.pipeline.RecordSettings`` of the run.
        step_hook: called after each step with (t, observation, ``Scene``).
    """

    def __init__(self, settings: RecordSettings, step_hook: StepHook | None = None):
        self.entry = registry.load(settings.task_name)
        self.policy_cls = self.entry.policy_class()
        self.layout_name = str(self.policy_cls.action_layout)
        if self.layout_name not in LAYOUTS:
            raise ValueError(
                f"policy {self.policy_cls.__name__}: action_layout {self.layout_name!r} is not "
                f"one of {sorted(LAYOUTS)}"
            )
        self.layout = LAYOUTS[self.layout_name]
        self.settings = settings
        self.step_hook = step_hook
        self.arm_limits = ArmLimits.from_mjcf()
        self.last_speed_limited = 0
        self.sampler = registry.make_sampler(self.entry.name, settings.sampler_settings())
        probe = self.sampler.make_task()
        self.policy_dt = probe.policy_dt
        self.fps = 1.0 / self.policy_dt
        self.max_reward = float(probe.max_reward)
        self.minimum_episode_len = int(getattr(self.policy_cls, "minimum_episode_len", 0))
        self.task = None

    @property
    def joint_scene(self):
        """The recorded world (``sim.scene.Scene``)."""
        return self.sampler.scene

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
        rng = np.random.default_rng(seed)
        task = self.task = self.sampler.next_task(rng)
        scene = self.sampler.scene
        poses = {name: obj.get_pose(scene.data) for name, obj in scene.objects.items()}
        policy = self.policy_cls(task, inject_noise=s.inject_noise, rng=rng)
        dtype = SCHEMA.array("action").dtype
        attrs = episode_attrs(
            s,
            self.entry.name,
            attempt,
            self.policy_dt,
            poses,
            self.sampler.randomization,
            extra_attrs,
            layout=self.layout_name,
            speed_limited_values=0,
        )

        def play(writer: EpisodeWriter) -> tuple[np.ndarray, bool, dict]:
            actions = np.empty((s.episode_len, self.layout.size))
            rewards = np.empty(s.episode_len)
            obs = task.get_observation()
            for t in range(s.episode_len):
                images = scene.render_images()
                qpos, qvel = task.recorded_state()
                # the file stores float32: act exactly on the stored values
                action = np.asarray(policy(obs), dtype=float).astype(dtype).astype(float)
                actions[t] = action
                env_state = obs["env_state"]
                obs, rewards[t], _ = task.step(self.layout.commands(action))
                writer.append(
                    qpos=qpos,
                    qvel=qvel,
                    action=action,
                    reward=rewards[t],
                    env_state=env_state,
                    images=images,
                )
                if self.step_hook is not None:
                    self.step_hook(t, obs, scene)
                if progress is not None:
                    progress()
            speed_ok, peak_use = self.check_real_replay(actions)
            checked = {"real_replay_checked": speed_ok, "peak_speed_fraction": peak_use}
            return rewards, speed_ok, checked

        return write_episode(s, path, attrs, play, self.max_reward, overwrite, create_folder)

    def check_real_replay(self, actions: np.ndarray) -> tuple[bool, float]:
        """The arms' 14 targets through the real-replay validator at the recording rate,
        and the base's commands within its limits. Returns (passed, the arms' largest speed
        as a fraction of its limit; NaN when the check failed)."""
        arms = KIT14_LAYOUT.to_vendor(actions[:, :14])
        robot = self.sampler.scene.robots[self.sampler.robot_name]
        base_ok = True
        if actions.shape[1] > 14 and "base" in robot.controllers:
            low, high = robot.controllers["base"].command_limits()
            base_ok = bool(np.all(actions[:, 14:] >= low) and np.all(actions[:, 14:] <= high))
        try:
            trajectory = validate_actions(arms, self.fps, self.arm_limits)
        except TrajectoryError:
            return False, float("nan")
        return base_ok, float(np.max(trajectory.peak_speed / self.arm_limits.velocity))

    def close(self) -> None:
        """Close the sampler and the scene (and renderers) it owns."""
        self.sampler.close()
