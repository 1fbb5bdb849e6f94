"""Two-phase data collection of one episode.

Phase 1: the scripted policy drives the end-effector (mocap) env; nothing is rendered. The
arm joint trajectory is kept, with the finger values replaced by the gripper commands.
Phase 2: that trajectory is replayed as actions in the joint env, which behaves like the real
arms; only the requested cameras are rendered, and every step is streamed to the episode
file, so memory stays flat in the episode length. Success is judged in phase 2.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.constants import SIM_TASK_CONFIGS
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask
from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.real.validate import (
    DATASET_JOINTS,
    ArmLimits,
    TrajectoryError,
    validate_actions,
)
from trossen_arm_mujoco.robot.configs import JOINT_VELOCITY_LIMITS
from trossen_arm_mujoco.scripted_policy import PickAndTransferPolicy
from trossen_arm_mujoco.sim_env import TransferCubeTask
from trossen_arm_mujoco.utils import make_sim_env

#: task name -> (EE task class, joint task class, scripted policy class)
SCRIPTED_TASKS: dict[str, tuple[type, type, type]] = {
    "sim_transfer_cube": (TransferCubeEETask, TransferCubeTask, PickAndTransferPolicy),
}


#: Recording rate of the scripted tasks (Hz): one action per 0.02 s control period.
RECORD_FPS = 50.0

#: Speed limit of each of the 16 action values (URDF: rad/s for the joints, m/s for both
#: finger values), in the qpos layout.
ACTION_SPEED_LIMITS = np.tile([JOINT_VELOCITY_LIMITS[j] for j in DATASET_JOINTS], 2)


def limit_speed(actions: np.ndarray, max_speed: np.ndarray, fps: float) -> int:
    """Rate-limit a ``(T, D)`` trajectory in place: every value moves at most
    ``max_speed / fps`` per step (``max_speed``: (D,), units per second). Returns how many
    values were changed (0 when the trajectory was already within the limits)."""
    max_step = np.asarray(max_speed, dtype=float) / fps
    changed = 0
    for t in range(1, len(actions)):
        step = actions[t] - actions[t - 1]
        fast = np.abs(step) > max_step
        if fast.any():
            changed += int(fast.sum())
            actions[t] = actions[t - 1] + np.clip(step, -max_step, max_step)
    return changed


def episode_seed(base_seed: int, attempt: int) -> int:
    """Seed of attempt ``attempt`` of a run with ``--seed base_seed`` (independent streams)."""
    return int(np.random.SeedSequence([int(base_seed), int(attempt)]).generate_state(1)[0])


@dataclass(frozen=True)
class RecordSettings:
    """What every episode of a run shares."""

    task_name: str = "sim_transfer_cube"
    episode_len: int = 600
    inject_noise: bool = False
    cam_names: tuple[str, ...] = ()
    height: int = 480
    width: int = 640
    compression: str = "none"
    base_seed: int = 0


@dataclass
class EpisodeOutcome:
    """Result of one recorded attempt."""

    attempt: int
    seed: int
    success: bool
    final_reward: float
    max_reward: float
    path: Path | None


#: (step, observation after the step, joint env) -> None
StepHook = Callable[[int, dict, object], None]


class EpisodeRecorder:
    """Owns the two envs (built once, reused for every episode) and records episodes.

    Args:
        settings: run settings (task, length, cameras, compression, seed).
        step_hook: called after each phase-2 step with (t, observation, joint env), e.g. a
            live view.
    """

    def __init__(self, settings: RecordSettings, step_hook: StepHook | None = None):
        if settings.task_name not in SCRIPTED_TASKS:
            raise unknown_name_error("task", settings.task_name, SCRIPTED_TASKS)
        ee_cls, joint_cls, self.policy_cls = SCRIPTED_TASKS[settings.task_name]
        self.settings = settings
        self.step_hook = step_hook
        limit = settings.episode_len * 0.02 + 1.0
        self.arm_limits = ArmLimits.from_mjcf()
        self.last_speed_limited = 0
        self.ee_env = make_sim_env(ee_cls, cam_list=[], time_limit=limit)
        self.joint_env = make_sim_env(
            joint_cls,
            cam_list=list(settings.cam_names),
            image_size=(settings.height, settings.width),
            time_limit=limit,
        )

    def scripted_rollout(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Phase 1. Returns (joint actions (T, 16), initial cube pose (7,)).

        The actions are within the joint limits and, at the recording rate of 50 Hz, within
        the real arm's joint and gripper speed limits (``ACTION_SPEED_LIMITS``): the scripted
        policies plan below them, and any value that would still be faster is rate-limited
        (``self.last_speed_limited`` counts them; normally 0).
        """
        T = self.settings.episode_len
        task = self.ee_env.task
        task.rng = rng
        ts = self.ee_env.reset()
        box_pose = np.asarray(ts.observation["env_state"], dtype=float).copy()
        policy = self.policy_cls(inject_noise=self.settings.inject_noise, rng=rng)
        actions = np.empty((T, 16))
        for t in range(T):
            ee_action = policy(ts)
            ts = self.ee_env.step(ee_action)
            actions[t] = ts.observation["qpos"]
            # Fingers: command the gripper targets, not the measured (blocked) finger travel,
            # so the joint env squeezes the cube as the EE env did.
            actions[t, 6:8] = ee_action[7]
            actions[t, 14:16] = ee_action[15]
        # The mocap weld can press a joint slightly past its (soft) limit; the joint env and
        # the real arm only accept targets within the limits, so record those.
        low, high = self.joint_env.task.action_bounds(self.joint_env.physics)
        np.clip(actions, low, high, out=actions)
        self.last_speed_limited = limit_speed(actions, ACTION_SPEED_LIMITS, RECORD_FPS)
        return actions, box_pose

    def replay(
        self,
        actions: np.ndarray,
        box_pose: np.ndarray,
        writer: EpisodeWriter | None = None,
        progress: Callable[[], None] | None = None,
    ) -> np.ndarray:
        """Phase 2: replay joint actions from ``box_pose``; returns rewards (T,).

        Each step appends (observation before the action, action, reward after it) to
        ``writer``; the observation after the last action is not rendered.
        """
        T = len(actions)
        task = self.joint_env.task
        task.box_pose = np.asarray(box_pose, dtype=float)
        task.render_enabled = True
        ts = self.joint_env.reset()
        rewards = np.empty(T)
        for t in range(T):
            obs = ts.observation
            task.render_enabled = t < T - 1
            ts = self.joint_env.step(actions[t])
            rewards[t] = ts.reward
            if writer is not None:
                writer.append(
                    qpos=obs["qpos"],
                    qvel=obs["qvel"],
                    action=actions[t],
                    reward=ts.reward,
                    env_state=obs["env_state"],
                    images=obs["images"],
                )
            if self.step_hook is not None:
                self.step_hook(t, ts.observation, self.joint_env)
            if progress is not None:
                progress()
        return rewards

    def record(
        self,
        attempt: int,
        path: Path,
        overwrite: bool = False,
        progress: Callable[[], None] | None = None,
        extra_attrs: dict | None = None,
    ) -> EpisodeOutcome:
        """Record attempt ``attempt`` (seed derived from the run seed) into ``path``."""
        s = self.settings
        seed = episode_seed(s.base_seed, attempt)
        rng = np.random.default_rng(seed)
        actions, box_pose = self.scripted_rollout(rng)
        max_reward = float(self.joint_env.task.max_reward)
        speed_ok, peak_use = self.check_real_replay(actions)
        attrs = {
            "task_name": s.task_name,
            "seed": seed,
            "base_seed": int(s.base_seed),
            "attempt": int(attempt),
            "inject_noise": bool(s.inject_noise),
            "box_pose": box_pose,
            "success": False,
            "real_replay_fps": RECORD_FPS,
            "real_replay_checked": speed_ok,
            "peak_speed_fraction": peak_use,
            "speed_limited_values": int(self.last_speed_limited),
            **(extra_attrs or {}),
        }
        with EpisodeWriter(
            path,
            episode_len=s.episode_len,
            camera_names=s.cam_names,
            height=s.height,
            width=s.width,
            compression=s.compression,
            attrs=attrs,
            overwrite=overwrite,
        ) as writer:
            rewards = self.replay(actions, box_pose, writer, progress)
            success = bool(rewards[-1] == max_reward) and speed_ok
            writer.set_attrs(
                success=success,
                final_reward=float(rewards[-1]),
                max_reward=float(rewards.max()),
            )
        return EpisodeOutcome(
            attempt, seed, success, float(rewards[-1]), float(rewards.max()), Path(path)
        )

    def check_real_replay(self, actions: np.ndarray) -> tuple[bool, float]:
        """Run the real-replay validator at the recording rate, as
        ``replay_episode_real.py --fps 50 --dry_run`` does. Returns (passed, largest
        speed as a fraction of its limit; NaN when the check failed)."""
        try:
            trajectory = validate_actions(actions, RECORD_FPS, self.arm_limits)
        except TrajectoryError:
            return False, float("nan")
        return True, float(np.max(trajectory.peak_speed / self.arm_limits.velocity))

    def close(self) -> None:
        for env in (self.ee_env, self.joint_env):
            env.task.close()


def default_cameras(task_name: str) -> list[str]:
    """The cameras a task records by default."""
    return list(SIM_TASK_CONFIGS[task_name]["cam_names"])
