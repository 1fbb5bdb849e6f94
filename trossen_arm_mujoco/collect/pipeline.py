"""Two-phase data collection of one episode, for any registered task with a scripted policy.

Phase 1: the scripted policy drives the end-effector (mocap) flavour; nothing is rendered;
the arm joint trajectory is kept, the finger values replaced by the gripper commands. Phase
2: that trajectory is replayed as actions in the joint flavour, which behaves like the real
arms, from the same initial object poses; only the requested cameras are rendered and each
step is streamed to the file (memory flat in the episode length). Success is judged in phase
2. With ``RecordSettings.randomize`` phase 1 samples the domain randomization and phase 2
applies the same record (stored as the ``randomization`` attribute). The task's
``policy_dt`` is the recording period; phase-1 actions are rounded to float32 before phase
2, so the stored ``/action`` is exactly what was replayed.

Docs: docs/cli/record.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.data.schema import DEFAULT_COMPRESSION, SCHEMA
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.real.validate import (
    DATASET_JOINTS,
    ArmLimits,
    TrajectoryError,
    validate_actions,
)
from trossen_arm_mujoco.robot.configs import JOINT_VELOCITY_LIMITS
from trossen_arm_mujoco.robot.layout import EE_LAYOUT, SIDES, VENDOR16_LAYOUT
from trossen_arm_mujoco.sim.camera_crop import CameraCrop, crop_texts, parse_crops
from trossen_arm_mujoco.sim.looks import SceneLooks
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.randomization_record import record_to_json
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

__all__ = [
    "ACTION_SPEED_LIMITS",
    "EpisodeOutcome",
    "EpisodePlay",
    "EpisodeRecorder",
    "RecordSettings",
    "StepHook",
    "TimeStep",
    "default_cameras",
    "episode_attrs",
    "episode_seed",
    "limit_speed",
    "policy_minimum_episode_len",
    "write_episode",
]

#: Speed limit of each of the 16 action values (URDF: rad/s for the joints, m/s for both
#: finger values), in the qpos layout.
ACTION_SPEED_LIMITS = np.tile([JOINT_VELOCITY_LIMITS[j] for j in DATASET_JOINTS], 2)


def limit_speed(actions: np.ndarray, max_speed: np.ndarray, fps: float) -> int:
    """Rate-limit a trajectory in place: every value moves at most ``max_speed / fps`` per
    step.

    Args:
        actions: ``(T, D)`` trajectory, changed in place.
        max_speed: ``(D,)`` speed limits, units per second (rad/s, m/s).
        fps: steps per second.

    Returns:
        How many values were changed (0 when already within the limits).
    """
    max_step = np.asarray(max_speed, dtype=float) / fps
    changed = 0
    for t in range(1, len(actions)):
        step = actions[t] - actions[t - 1]
        fast = np.abs(step) > max_step
        if fast.any():
            changed += int(fast.sum())
            actions[t] = actions[t - 1] + np.clip(step, -max_step, max_step)
    return changed


class TimeStep:
    """What a scripted policy is called with: ``ts.observation`` (dict), as in dm_control."""

    __slots__ = ("observation",)

    def __init__(self, observation: dict):
        self.observation = observation


def episode_seed(base_seed: int, attempt: int) -> int:
    """Seed of attempt ``attempt`` of a run with ``--seed base_seed`` (independent streams)."""
    return int(np.random.SeedSequence([int(base_seed), int(attempt)]).generate_state(1)[0])


@dataclass(frozen=True)
class RecordSettings:
    """What every episode of a run shares."""

    task_name: str = registry.DEFAULT_TASK
    episode_len: int = 600
    inject_noise: bool = False
    cam_names: tuple[str, ...] = ()
    height: int = 480
    width: int = 640
    compression: str = DEFAULT_COMPRESSION
    base_seed: int = 0
    randomize: bool = False
    shadows: bool = True  # the key light casts shadows in the images
    antialias: bool = True  # edges smoothed by multisampling (sim.looks)
    visual: str = "own"  # arm meshes: "own" or "menagerie" (sim.looks)
    # cameras showing a rectangle: sim.camera_crop.CameraCrop values (--crop texts accepted)
    crops: tuple[CameraCrop | str, ...] = ()

    def sampler_settings(self, flavour: str = "joint") -> SamplerSettings:
        """How the sampler of ``flavour`` is built: the joint flavour renders the cameras
        (``cam_names`` at ``height`` x ``width`` px) with the run's looks; the ee flavour
        (the scripted rollout) renders nothing. Both randomize as ``randomize`` says."""
        if flavour == "ee":
            return SamplerSettings(flavour="ee", randomize=self.randomize)
        return SamplerSettings(
            flavour=flavour,
            camera_names=self.cam_names,
            height=self.height,
            width=self.width,
            randomize=self.randomize,
            looks=SceneLooks(
                shadows=self.shadows,
                antialias=self.antialias,
                visual=self.visual,
                crops=parse_crops(self.crops),
            ),
        )


@dataclass
class EpisodeOutcome:
    """Result of one recorded attempt.

    Attributes:
        final_reward, max_reward: last and largest reward of the episode.
        task_max_reward: the task's full reward (success needs it at the last step).
        real_replay_checked: the actions pass the real-arm check at the recording rate.
        nbytes: size of the episode file (bytes), 0 when unknown.
    """

    attempt: int
    seed: int
    success: bool
    final_reward: float
    max_reward: float
    path: Path | None
    task_max_reward: float = float("nan")
    real_replay_checked: bool = True
    nbytes: int = 0

    def failure(self) -> str | None:
        """Why the episode failed, in a few words; None for a success."""
        if self.success:
            return None
        if math.isnan(self.task_max_reward):  # the task judges success itself (single arm)
            if not self.real_replay_checked:
                return "actions fail the real-arm speed check"
            return "the task's success test failed"
        if not self.final_reward >= self.task_max_reward:
            return f"reward below max {self.task_max_reward:g}"
        if not self.real_replay_checked:
            return "actions fail the real-arm speed check"
        return "not successful"


#: (step, observation after the step, joint scene) -> None
StepHook = Callable[[int, dict, object], None]


class EpisodeRecorder:
    """Owns the task's two flavours (built once, reused for every episode) and records
    episodes.

    Args:
        settings: run settings (task, length, cameras, compression, seed).
        step_hook: called after each phase-2 step with (t, observation, joint ``Scene``),
            e.g. a live view.
    """

    def __init__(self, settings: RecordSettings, step_hook: StepHook | None = None):
        self.entry = registry.load(settings.task_name)
        self.policy_cls = self.entry.policy_class()
        self.settings = settings
        self.step_hook = step_hook
        self.arm_limits = ArmLimits.from_mjcf()
        self.last_speed_limited = 0
        self.ee_sampler = registry.make_sampler(self.entry.name, settings.sampler_settings("ee"))
        self.joint_sampler = registry.make_sampler(self.entry.name, settings.sampler_settings())
        #: randomization record of the last scripted rollout (None: not randomizing).
        self.last_randomization: dict | None = None
        self.ee_task = None
        self.joint_task = None
        probe = self.joint_sampler.make_task()
        self.policy_dt = probe.policy_dt
        self.fps = 1.0 / self.policy_dt
        self.max_reward = float(probe.max_reward)
        #: Steps the scripted policy needs to finish the task (0 when it does not say).
        self.minimum_episode_len = int(getattr(self.policy_cls, "minimum_episode_len", 0))
        view = self.joint_sampler.scene.robots[probe.robot_name].view
        ranges = np.concatenate(
            [view.get_move_group(g).joint_range for g in VENDOR16_LAYOUT.groups]
        )
        self.action_low, self.action_high = ranges[:, 0].copy(), ranges[:, 1].copy()

    @property
    def joint_scene(self):
        """The joint-flavour world (``sim.scene.Scene``)."""
        return self.joint_sampler.scene

    @property
    def ee_scene(self):
        """The end-effector-flavour world (``sim.scene.Scene``)."""
        return self.ee_sampler.scene

    def scripted_rollout(
        self, rng: np.random.Generator, object_poses: dict | None = None
    ) -> tuple[np.ndarray, dict]:
        """Phase 1. Returns (joint actions (T, 16), initial object poses {name: (7,)}).

        ``object_poses`` places the objects instead of the sampled poses (the scripted
        reference of an evaluation episode); the generator still drives the sampling.

        The actions are within the joint limits and, at the recording rate (50 Hz), within
        the real arm's joint and gripper speed limits (``ACTION_SPEED_LIMITS``): the scripted
        policies plan below them, and any value that would still be faster is rate-limited
        (``self.last_speed_limited`` counts them; normally 0). With randomization, its
        record is kept in ``self.last_randomization`` for the replay.
        """
        T = self.settings.episode_len
        task = self.ee_task = self.ee_sampler.next_task(rng, object_poses=object_poses)
        self.last_randomization = self.ee_sampler.randomization
        poses = task.object_poses()
        policy = self.policy_cls(inject_noise=self.settings.inject_noise, rng=rng)
        actions = np.empty((T, VENDOR16_LAYOUT.size))
        ts = TimeStep(task.policy_observation())
        for t in range(T):
            ee_action = np.asarray(policy(ts), dtype=float)
            task.step(EE_LAYOUT.commands(ee_action))
            obs = task.policy_observation()
            ts = TimeStep(obs)
            actions[t] = obs["qpos"]
            # Fingers: command the gripper targets, not the measured (blocked) finger travel,
            # so the joint flavour squeezes the objects as the EE flavour did.
            for side in SIDES:
                grip = ee_action[EE_LAYOUT.groups[f"{side}_gripper"]][0]
                actions[t, VENDOR16_LAYOUT.fingers(side)] = grip
        # The mocap weld can press a joint slightly past its (soft) limit; the joint flavour
        # and the real arm only accept targets within the limits, so record those.
        np.clip(actions, self.action_low, self.action_high, out=actions)
        self.last_speed_limited = limit_speed(actions, ACTION_SPEED_LIMITS, self.fps)
        # The file stores the schema's dtype (float32): replay exactly the stored values.
        actions[:] = actions.astype(SCHEMA.array("action").dtype)
        return actions, poses

    def scripted_success(self) -> bool:
        """Whether phase 1 ended in success (the EE flavour's judgement)."""
        return self.ee_task is not None and bool(self.ee_task.judge_success())

    def replay(
        self,
        actions: np.ndarray,
        object_poses: dict,
        writer: EpisodeWriter | None = None,
        progress: Callable[[], None] | None = None,
        randomization: dict | None = None,
    ) -> np.ndarray:
        """Phase 2: replay joint actions from ``object_poses``; returns rewards (T,).

        Each step appends (observation before the action, action, reward after it) to
        ``writer``; the observation after the last action is not rendered.

        Args:
            actions: ``(T, 16)`` joint actions (rad; m).
            object_poses: object name -> initial pose (7,) [xyz m, quat wxyz].
            writer: where each step goes; None: nothing is written.
            progress: called after every step.
            randomization: the randomization record to apply; None: the last scripted
                rollout's.
        """
        rewards = np.empty(len(actions))
        for _ in self.replay_steps(actions, object_poses, rewards, writer, randomization):
            if progress is not None:
                progress()
        return rewards

    def replay_steps(
        self,
        actions: np.ndarray,
        object_poses: dict,
        rewards: np.ndarray,
        writer: EpisodeWriter | None = None,
        randomization: dict | None = None,
    ) -> Iterator[int]:
        """:meth:`replay`, one step per iteration: yields ``t`` after step ``t`` (rendered,
        stepped, written; ``rewards[t]`` set), so a caller can interleave it with other
        work (``benchmarks/record_episode.py`` times it against raw MuJoCo that way).

        Args:
            actions: ``(T, 16)`` joint actions (rad; m).
            object_poses: object name -> initial pose (7,) [xyz m, quat wxyz].
            rewards: ``(T,)`` array that receives the rewards.
            writer: where each step goes; None: nothing is written.
            randomization: as for :meth:`replay`.
        """
        if randomization is None:
            randomization = self.last_randomization
        task = self.joint_task = self.joint_sampler.next_task(
            0, object_poses=object_poses, randomization=randomization
        )
        scene = self.joint_sampler.scene
        obs = task.get_observation()
        for t in range(len(actions)):
            images = scene.render_images() if writer is not None else {}
            task.step(VENDOR16_LAYOUT.joint_commands(actions[t]))
            rewards[t] = task.get_reward()
            if writer is not None:
                writer.append(
                    qpos=obs["qpos"],
                    qvel=obs["qvel"],
                    action=actions[t],
                    reward=rewards[t],
                    env_state=obs["env_state"],
                    images=images,
                )
            obs = task.get_observation()
            if self.step_hook is not None:
                self.step_hook(t, obs, scene)
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
        rng = np.random.default_rng(seed)
        actions, poses = self.scripted_rollout(rng)
        speed_ok, peak_use = self.check_real_replay(actions)
        attrs = episode_attrs(
            s,
            self.entry.name,
            attempt,
            self.policy_dt,
            poses,
            self.last_randomization,
            extra_attrs,
            **({"box_pose": poses["box"]} if "box" in poses else {}),
            real_replay_checked=speed_ok,
            peak_speed_fraction=peak_use,
            speed_limited_values=int(self.last_speed_limited),
        )

        def play(writer: EpisodeWriter) -> tuple[np.ndarray, bool, dict]:
            return self.replay(actions, poses, writer, progress), speed_ok, {}

        return write_episode(s, path, attrs, play, self.max_reward, overwrite, create_folder)

    def check_real_replay(self, actions: np.ndarray) -> tuple[bool, float]:
        """Run the real-replay validator at the recording rate (1 / policy_dt), as
        ``replay_episode_real.py --fps 50 --dry_run`` does. Returns (passed, largest speed
        as a fraction of its limit; NaN when the check failed)."""
        try:
            trajectory = validate_actions(actions, self.fps, self.arm_limits)
        except TrajectoryError:
            return False, float("nan")
        return True, float(np.max(trajectory.peak_speed / self.arm_limits.velocity))

    def close(self) -> None:
        """Close both samplers and the envs (and renderers) they own."""
        self.ee_sampler.close()
        self.joint_sampler.close()


def episode_attrs(
    settings: RecordSettings,
    task_name: str,
    attempt: int,
    dt: float,
    poses: dict,
    randomization: dict | None,
    extra_attrs: dict | None = None,
    **fields,
) -> dict:
    """The root attributes of a recorded episode file: the run's, then the recorder's
    ``fields``, then the caller's ``extra_attrs``. ``success`` starts False;
    ``write_episode`` sets it.

    Args:
        settings: the run's settings.
        task_name: the registered task.
        attempt: the attempt number (its seed is stored).
        dt: seconds per recorded step.
        poses: the objects' initial poses {name: (7,) [xyz m, quat wxyz]}.
        randomization: the randomization record (stored as JSON), or None.
        extra_attrs: the caller's attributes.
        **fields: the recorder's attributes.
    """
    s = settings
    attrs = {
        "task_name": task_name,
        "seed": episode_seed(s.base_seed, attempt),
        "base_seed": int(s.base_seed),
        "attempt": int(attempt),
        "inject_noise": bool(s.inject_noise),
        "dt": dt,
        "initial_env_state": np.concatenate(list(poses.values())),
        "object_names": list(poses),
        "success": False,
        "real_replay_fps": 1.0 / dt,
        "shadows": bool(s.shadows),
        "antialias": bool(s.antialias),
        "visual": s.visual,
        **({"crops": crop_texts(s.crops)} if s.crops else {}),
        **fields,
        **(extra_attrs or {}),
    }
    if randomization is not None:
        attrs["randomization"] = record_to_json(randomization)
    return attrs


#: (open episode writer) -> (rewards (T,), real-replay check passed, attributes to add)
EpisodePlay = Callable[[EpisodeWriter], tuple[np.ndarray, bool, dict]]


def write_episode(
    settings: RecordSettings,
    path: Path,
    attrs: dict,
    play: EpisodePlay,
    max_reward: float,
    overwrite: bool = False,
    create_folder: bool = True,
    judge: Callable[[], bool] | None = None,
) -> EpisodeOutcome:
    """Write one episode file with ``play`` streaming its steps, and judge it.

    The file is ``data.writer.EpisodeWriter``'s: written to a temporary file and renamed
    into ``path`` only when ``play`` returns (atomic), never over an existing file unless
    ``overwrite``; ``create_folder=False`` needs the folder to exist. Success: the last
    reward equals ``max_reward`` (or, with ``judge``, ``judge()`` called after ``play``: the
    task's own success test, ``max_reward`` then NaN) and the real-replay check passed;
    ``success``, ``final_reward``, ``max_reward`` and ``play``'s attributes are set on the
    file.

    Args:
        settings: the run's settings (episode length, cameras, image size, compression).
        path: the episode file.
        attrs: the root attributes (:func:`episode_attrs`).
        play: streams the steps into the writer it is given.
        max_reward: the task's maximum reward (NaN with ``judge``).
        overwrite: replace a file already at ``path``.
        create_folder: create ``path``'s folder if missing.
        judge: the task's own success test, called after ``play``.
    """
    s = settings
    with EpisodeWriter(
        path,
        episode_len=s.episode_len,
        camera_names=s.cam_names,
        height=s.height,
        width=s.width,
        compression=s.compression,
        attrs=attrs,
        env_state_dim=len(attrs["initial_env_state"]),
        overwrite=overwrite,
        create_folder=create_folder,
    ) as writer:
        rewards, speed_ok, more = play(writer)
        reached = judge() if judge is not None else rewards[-1] == max_reward
        success = bool(reached) and speed_ok
        writer.set_attrs(
            success=success,
            final_reward=float(rewards[-1]),
            max_reward=float(rewards.max()),
            **more,
        )
    return EpisodeOutcome(
        int(attrs["attempt"]),
        int(attrs["seed"]),
        success,
        float(rewards[-1]),
        float(rewards.max()),
        Path(path),
        task_max_reward=max_reward,
        real_replay_checked=speed_ok,
        nbytes=Path(path).stat().st_size,
    )


def default_cameras(task_name: str) -> list[str]:
    """The cameras a task records by default."""
    return list(registry.load(task_name).record["cam_names"])


def policy_minimum_episode_len(task_name: str) -> int:
    """Steps the task's scripted policy needs to finish (0 when it does not say); no
    model is built."""
    return int(getattr(registry.load(task_name).policy_class(), "minimum_episode_len", 0))
