"""Teleoperation: two leader arms drive the simulated followers of a kit task, recording
demonstrations (``trossen-mujoco teleop``; the command line is ``scripts/teleop.py``).

The leaders (:class:`~trossen_arm_mujoco.twin.leader_arms.LeaderArms`, real or served) are
read in external_effort mode; each step's reading is the kit's 14-value joint action (rad,
gripper m) of the task's joint flavour, clipped to the joint ranges and to the real arm's
speed limits at the recording rate. Steps are recorded as ``record`` records them, spooled
(:class:`~.episode_spool.EpisodeSpool`) and written only when an episode ends and is kept.

Docs: docs/cli/teleop.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from trossen_arm_mujoco.data.schema import DEFAULT_COMPRESSION, SCHEMA
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.real.validate import (
    VELOCITY_LIMITS,
    ArmLimits,
    TrajectoryError,
    validate_actions,
)
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, SIDES, VENDOR16_LAYOUT
from trossen_arm_mujoco.sim.looks import SceneLooks
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.randomization_record import record_to_json
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.twin.episode_spool import EpisodeSpool
from trossen_arm_mujoco.twin.leader_arms import LeaderArms

__all__ = [
    "ARM_COLUMNS",
    "KIT_SPEED_LIMITS",
    "EpisodeControl",
    "TeleopOutcome",
    "TeleopRecorder",
    "TeleopSettings",
    "object_poses_from",
]

#: Speed limit (per second) of each of the 14 kit values: rad/s x6, gripper m/s, per arm.
KIT_SPEED_LIMITS: np.ndarray = np.tile(np.asarray(VELOCITY_LIMITS, dtype=float), 2)
#: The 12 arm-joint columns of the 14 kit values (tracking error is measured on them).
ARM_COLUMNS: np.ndarray = np.r_[KIT14_LAYOUT.arm("left"), KIT14_LAYOUT.arm("right")]


class EpisodeControl(Protocol):
    """The operator's commands during an episode."""

    def poll(self) -> str | None:
        """``"end"`` (keep the episode as it is), ``"discard"``, or None (carry on)."""
        ...


@dataclass(frozen=True)
class TeleopSettings:
    """What every teleoperated episode of a run shares.

    Attributes:
        task_name: a kit task of the registry (``sim_transfer_cube``, ``sim_insertion``).
        episode_len: most steps per episode.
        cam_names, height, width: cameras recorded and their image size (px).
        compression: image compression of the episode files.
        overrides: task config overrides (the rate: ``policy_dt``, ``ctrl_dt``, ``sim_dt``).
        shadows, antialias, visual: scene looks (``sim.looks.SceneLooks``).
    """

    task_name: str = registry.DEFAULT_TASK
    episode_len: int = 600
    cam_names: tuple[str, ...] = ()
    height: int = 480
    width: int = 640
    compression: str = DEFAULT_COMPRESSION
    overrides: Mapping[str, float] = field(default_factory=dict)
    shadows: bool = True
    antialias: bool = True
    visual: str = "own"

    def sampler_settings(self) -> SamplerSettings:
        """How the follower world's sampler is built: the joint flavour rendering
        ``cam_names`` at ``height`` x ``width`` px with the run's looks."""
        return SamplerSettings(
            camera_names=self.cam_names,
            height=self.height,
            width=self.width,
            looks=SceneLooks(shadows=self.shadows, antialias=self.antialias, visual=self.visual),
        )


@dataclass
class TeleopOutcome:
    """One kept episode.

    Attributes:
        num_steps: steps recorded; ``ended_by``: ``"episode_len"`` or ``"operator"``.
        final_reward, max_reward, task_max_reward: last, largest and full reward.
        speed_limited_values: values clipped to the speed limit; ``ramp_steps``: steps
            before the followers first matched the leaders.
        tracking_rms: RMS (rad) of follower arm joints minus leader arm joints after the
            ramp (NaN when the ramp never ended).
        achieved_fps: steps per second of wall-clock time; ``overruns``: late steps.
    """

    index: int
    seed: int
    path: Path
    num_steps: int
    ended_by: str
    success: bool
    final_reward: float
    max_reward: float
    task_max_reward: float
    speed_limited_values: int
    ramp_steps: int
    tracking_rms: float
    achieved_fps: float
    overruns: int
    real_replay_checked: bool
    nbytes: int


class TeleopRecorder:
    """Owns the task's joint flavour (built once) and records teleoperated episodes.

    Args:
        settings: the run's settings.
        step_hook: called after each step with (t, observation, joint ``Scene``,
            images), e.g. a live view.
    """

    def __init__(
        self,
        settings: TeleopSettings,
        step_hook: Callable[[int, dict, Any, dict], None] | None = None,
    ) -> None:
        self.entry = registry.load(settings.task_name)
        if settings.task_name not in registry.kit_names():
            raise unknown_name_error(
                "kit task",
                settings.task_name,
                registry.kit_names(),
                "teleop drives the Stationary AI kit's two arms",
            )
        self.settings = settings
        self.step_hook = step_hook
        self.sampler = registry.make_sampler(
            self.entry.name, settings.sampler_settings(), **dict(settings.overrides)
        )
        probe = self.sampler.make_task()
        self.policy_dt = float(probe.policy_dt)
        self.fps = 1.0 / self.policy_dt
        self.task_max_reward = float(probe.max_reward)
        view = self.sampler.scene.robots[probe.robot_name].view
        ranges = np.concatenate(
            [view.get_move_group(g).joint_range for g in VENDOR16_LAYOUT.groups]
        )
        self.low = KIT14_LAYOUT.from_vendor(ranges[:, 0])
        self.high = KIT14_LAYOUT.from_vendor(ranges[:, 1])
        self.max_step = KIT_SPEED_LIMITS * self.policy_dt
        self.arm_limits = ArmLimits.from_mjcf()
        self.task = None
        self._rendered = False

    @property
    def scene(self):
        """The joint-flavour world (``sim.scene.Scene``)."""
        return self.sampler.scene

    def start_episode(self, seed: int, object_poses: Mapping[str, Any] | None = None):
        """Reset the scene for an episode: objects drawn from ``seed`` as ``record`` draws
        them (``default_rng(seed)`` into the task sampler), or placed at ``object_poses``."""
        rng = np.random.default_rng(int(seed))
        self.task = self.sampler.next_task(rng, object_poses=object_poses)
        return self.task

    def record_episode(
        self,
        index: int,
        seed: int,
        path: Path,
        leaders: LeaderArms,
        control: EpisodeControl | None = None,
        object_poses: Mapping[str, Any] | None = None,
        extra_attrs: Mapping[str, Any] | None = None,
    ) -> TeleopOutcome | None:
        """Teleoperate and record episode ``index`` into ``path``; None when the operator
        discarded it. A :class:`LeaderFault` or an interrupt discards it too (and passes).

        Args:
            index: the episode's index in the folder.
            seed: the run seed (the scene of ``record``'s episode ``index``).
            path: the episode file to write.
            leaders: the leader arms read.
            control: the operator's commands (``end``, ``discard``); None: none.
            object_poses: object name -> pose (7,) [x, y, z, qw, qx, qy, qz] (m, world) instead of
                the sampled ones.
            extra_attrs: more attributes of the episode file.
        """
        task = self.start_episode(seed, object_poses)
        poses = task.object_poses()
        s = self.settings
        spool = EpisodeSpool(path.parent, s.cam_names, s.height, s.width, anonymous=True)
        try:
            if spool.camera_names and not self._rendered:  # the first render sets up the renderer
                self.scene.render_images()
                self._rendered = True
            run = self._run(task, spool, leaders, control)
            if run is None:
                return None
            return self._write(index, seed, path, spool, poses, run, leaders, extra_attrs)
        finally:
            spool.discard()

    def _run(self, task, spool: EpisodeSpool, leaders: LeaderArms, control: EpisodeControl | None):
        """The paced loop; returns its statistics, or None when discarded."""
        scene = self.scene
        obs = task.get_observation()
        command = KIT14_LAYOUT.from_vendor(np.asarray(obs["qpos"], dtype=float))
        command = np.clip(command, self.low, self.high)
        clips, ramp_steps, errors = 0, -1, []
        ended_by = "episode_len"
        period = self.policy_dt
        start_wall = time.time()
        start = next_tick = time.monotonic()
        overruns = 0
        dtype = SCHEMA.array("action").dtype
        for t in range(self.settings.episode_len):
            target = np.clip(leaders.read(), self.low, self.high)
            step = np.clip(target - command, -self.max_step, self.max_step)
            fast = int(np.count_nonzero(step != target - command))
            clips += fast
            command = (command + step).astype(dtype).astype(float)  # recorded as float32
            if ramp_steps < 0 and fast == 0:
                ramp_steps = t
            action = KIT14_LAYOUT.to_vendor(command)
            images = scene.render_images() if spool.camera_names else {}
            task.step(VENDOR16_LAYOUT.joint_commands(action))
            reward = float(task.get_reward())
            spool.append_step(obs["qpos"], obs["qvel"], action, reward, obs["env_state"], images)
            obs = task.get_observation()
            if ramp_steps >= 0:
                follower = KIT14_LAYOUT.from_vendor(np.asarray(obs["qpos"], dtype=float))
                errors.append(follower[ARM_COLUMNS] - target[ARM_COLUMNS])
            if self.step_hook is not None:
                self.step_hook(t, obs, scene, images)
            order = control.poll() if control is not None else None
            if order == "discard":
                return None
            if order == "end":
                ended_by = "operator"
                break
            next_tick += period
            delay = next_tick - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:
                overruns += 1
                if delay < -period:  # fell behind by more than a step: do not spiral
                    next_tick = time.monotonic()
        elapsed = time.monotonic() - start
        n = len(spool)
        rms = float(np.sqrt(np.mean(np.square(errors)))) if errors else float("nan")
        return {
            "ended_by": ended_by,
            "speed_limited_values": clips,
            "ramp_steps": ramp_steps if ramp_steps >= 0 else n,
            "tracking_rms": rms,
            "achieved_fps": n / elapsed if elapsed > 0 else float("nan"),
            "overruns": overruns,
            "start_time": start_wall,
            "start_monotonic": start,
        }

    def check_real_replay(self, actions: np.ndarray) -> tuple[bool, float]:
        """Whether ``actions`` pass the real-replay check at the recording rate, and their
        largest speed as a fraction of its limit (NaN when they fail)."""
        try:
            trajectory = validate_actions(actions, self.fps, self.arm_limits)
        except TrajectoryError:
            return False, float("nan")
        return True, float(np.max(trajectory.peak_speed / self.arm_limits.velocity))

    def _write(
        self, index, seed, path: Path, spool: EpisodeSpool, poses, run, leaders, extra_attrs
    ):
        n = len(spool)
        rewards = spool.rewards
        speed_ok, peak = self.check_real_replay(spool.actions)
        success = bool(rewards[-1] >= self.task_max_reward) and speed_ok
        sampler_record = self.sampler.randomization
        attrs = {
            "task_name": self.entry.name,
            "seed": int(seed),
            "attempt": int(index),
            "dt": self.policy_dt,
            **({"box_pose": poses["box"]} if "box" in poses else {}),
            "initial_env_state": np.concatenate(list(poses.values())),
            "object_names": list(poses),
            "success": success,
            "final_reward": float(rewards[-1]),
            "max_reward": float(rewards.max()),
            "real_replay_fps": self.fps,
            "real_replay_checked": speed_ok,
            "peak_speed_fraction": peak,
            "speed_limited_values": int(run["speed_limited_values"]),
            "shadows": bool(self.settings.shadows),
            "antialias": bool(self.settings.antialias),
            "visual": self.settings.visual,
            "teleop": True,
            "leader_ips": [leaders.ips[s] for s in SIDES],
            "leader_end_effector": leaders.end_effector_name,
            "ended_by": run["ended_by"],
            "ramp_steps": int(run["ramp_steps"]),
            "tracking_rms_rad": float(run["tracking_rms"]),
            "achieved_fps": float(run["achieved_fps"]),
            "loop_overruns": int(run["overruns"]),
            "start_time": float(run["start_time"]),
            "start_monotonic": float(run["start_monotonic"]),
            **(dict(extra_attrs or {})),
        }
        if sampler_record is not None:
            attrs["randomization"] = record_to_json(sampler_record)
        spool.publish(path, attrs, self.settings.compression)
        return TeleopOutcome(
            index=int(index),
            seed=int(seed),
            path=Path(path),
            num_steps=n,
            ended_by=run["ended_by"],
            success=success,
            final_reward=float(rewards[-1]),
            max_reward=float(rewards.max()),
            task_max_reward=self.task_max_reward,
            speed_limited_values=int(run["speed_limited_values"]),
            ramp_steps=int(run["ramp_steps"]),
            tracking_rms=float(run["tracking_rms"]),
            achieved_fps=float(run["achieved_fps"]),
            overruns=int(run["overruns"]),
            real_replay_checked=speed_ok,
            nbytes=Path(path).stat().st_size,
        )

    def close(self) -> None:
        """Close the sampler and the scene (renderers) it owns."""
        self.sampler.close()


def object_poses_from(path: str, task_name: str) -> dict[str, np.ndarray]:
    """The initial object poses of a recorded episode (``initial_env_state`` with
    ``object_names``, else ``box_pose``), for a teleoperated episode in the same scene.

    Raises:
        UserError: unreadable file, another task, or no recorded object poses.
    """
    from trossen_arm_mujoco.data.reader import load_episode

    episode = load_episode(path)
    recorded_task = episode.attrs.get("task_name")
    if recorded_task is not None and registry.canonical(str(recorded_task)) != task_name:
        raise UserError(
            f"{path} is an episode of '{recorded_task}', not of '{task_name}'; pass "
            f"--task_name {recorded_task} or another episode"
        )
    names = episode.attrs.get("object_names")
    state = episode.attrs.get("initial_env_state")
    if names is not None and state is not None:
        names = [names] if isinstance(names, str) else list(names)
        values = np.asarray(state, dtype=float).reshape(-1, 7)
        if len(values) == len(names):
            return {name: values[i] for i, name in enumerate(names)}
    if episode.box_pose is not None:
        return {"box": episode.box_pose}
    if episode.env_state is not None and episode.env_state.shape[1] == 7:
        return {"box": episode.env_state[0]}
    raise UserError(f"{path} records no initial object poses (no initial_env_state or box_pose)")
