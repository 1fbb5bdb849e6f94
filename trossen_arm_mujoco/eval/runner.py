"""Run a policy over evaluation seeds in the sim, on local worker processes or Ray.

Episode ``i`` of a run with base seed S is ``env.reset(seed=S + i)``, the seeds
``lerobot-eval --seed S`` uses, so both tools score the same episodes (none of them a
recording episode). Each worker builds its env and policy once; episodes come back in order;
the first ``videos`` rollouts are written as mp4. The scores go to ``eval_info.json``
(``eval.scores``), each rollout's analysis to ``rollouts.json`` (``eval.rollout_analysis``).
Local workers are this process and a ``worker_pool.WorkerPool``'s, each with its share of the
CPU threads (``threads_per_worker``).

Docs: docs/cli/eval.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.action_check import check_action
from trossen_arm_mujoco.eval.env import KitPolicyEnv
from trossen_arm_mujoco.eval.rollout_analysis import RolloutRecorder
from trossen_arm_mujoco.eval.scores import EpisodeScore, eval_info, stages_reached
from trossen_arm_mujoco.processes import available_cpus
from trossen_arm_mujoco.sim.camera_settings import CameraSettings
from trossen_arm_mujoco.tasks.registry import DEFAULT_TASK
from trossen_arm_mujoco.worker_pool import WorkerPool, in_order

__all__ = [
    "ENGINES",
    "THREAD_VARS",
    "VIDEO_DIR",
    "WORKERS_DIED_ADVICE",
    "EpisodeRunner",
    "EvalSettings",
    "PolicyCallError",
    "evaluate",
    "limit_threads",
    "thread_env",
    "threads_per_worker",
]

#: The end of the one line when a worker died on the same episode each time.
WORKERS_DIED_ADVICE = "rerun with fewer --num_workers"
#: Where the rollout videos go, in the output folder.
VIDEO_DIR = "videos"
#: Environment variables sizing the thread pools of numpy's BLAS, OpenMP (torch) and MKL.
THREAD_VARS = (
    "OMP_NUM_THREADS",
    "MKL_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
)


class PolicyCallError(RuntimeError):
    """The policy itself raised (not a user error of the command line): the message says
    which policy, episode and step; the policy's own exception is the cause."""


def threads_per_worker(workers: int, cpus: int | None = None) -> int:
    """Threads each of ``workers`` processes gets on ``cpus`` cores: ``max(1, cpus // workers)``."""
    return max(1, (available_cpus() if cpus is None else cpus) // max(1, workers))


@contextmanager
def thread_env(threads: int) -> Iterator[None]:
    """``THREAD_VARS`` set to ``threads`` in this process's environment for the block (the
    processes it starts inherit them), restored afterwards."""
    saved = {k: os.environ.get(k) for k in THREAD_VARS}
    os.environ.update({k: str(threads) for k in THREAD_VARS})
    try:
        yield
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def limit_threads(threads: int, policy: str) -> None:
    """Size this process's pools to ``threads``: ``THREAD_VARS`` (for libraries loaded later)
    and torch's intra- and inter-op threads when torch is loaded or the policy is a
    checkpoint (torch is not imported for the scripted policy)."""
    from trossen_arm_mujoco.eval.policies import is_function_spec

    os.environ.update({k: str(threads) for k in THREAD_VARS})
    if "torch" not in sys.modules and (policy == "scripted" or is_function_spec(policy)):
        return
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(threads)
    try:
        torch.set_num_interop_threads(threads)
    except RuntimeError:  # only once, before any inter-op work: already fixed
        pass


@dataclass(frozen=True)
class EvalSettings:
    """What every episode of an evaluation shares (the CLI's flags); ``cameras``: what the
    policy's cameras observe (``sim.camera_settings``; default none)."""

    policy: str = "scripted"
    task: str = DEFAULT_TASK
    num_episodes: int = 10
    seed: int = 0
    cameras: CameraSettings = field(default_factory=CameraSettings)
    fps: float | None = None
    episode_length: int | None = None
    layout: str = "kit14"
    videos: int = 0
    output_dir: str = "eval"
    device: str = "cpu"
    #: the arm controller's checks on every setpoint (a fault ends the episode, failed)
    controller_checks: bool = True
    #: each episode's scene randomized (``KitPolicyEnv``'s ``randomize``), by
    #: ``randomization`` (a section replacing the task's; None: the task's own)
    randomize: bool = False
    randomization: dict[str, Any] | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def make_env(self) -> KitPolicyEnv:
        """A ``KitPolicyEnv`` of these settings (task, cameras, fps, episode length,
        layout), rendering ``rgb_array`` frames for the videos; a single arm's task: an
        ``eval.arm_env.ArmPolicyEnv`` of them."""
        from trossen_arm_mujoco.eval.arm_env import ArmPolicyEnv
        from trossen_arm_mujoco.eval.arm_tasks import is_arm_task

        env_cls = ArmPolicyEnv if is_arm_task(self.task) else KitPolicyEnv
        return env_cls(
            self.task,
            cameras=self.cameras,
            fps=self.fps,
            episode_length=self.episode_length,
            layout=self.layout,
            render_mode="rgb_array",
            controller_checks=self.controller_checks,
            randomize=self.randomize,
            randomization=self.randomization,
        )

    def run_block(self) -> dict[str, Any]:
        """The settings as ``eval_info.json``'s ``run`` block: every field but ``extra``,
        the cameras as their file form (``cam_names``, ``image_size``, ``crops``)."""
        run: dict[str, Any] = {}
        for f in fields(self):
            if f.name == "cameras":
                run.update(self.cameras.to_json())
            elif f.name != "extra":
                run[f.name] = getattr(self, f.name)
        return run


class EpisodeRunner:
    """One env and one policy, built once; runs episodes by index. ``threads``: this process's
    thread pools (``limit_threads``), sized before the policy is built (None: unchanged)."""

    def __init__(self, settings: EvalSettings, threads: int | None = None):
        from trossen_arm_mujoco.eval.policies import make_policy

        if threads is not None:
            limit_threads(threads, settings.policy)
        self.settings = settings
        self.env = settings.make_env()
        self.recorder = RolloutRecorder(self.env.task_name, self.env.fps)
        try:
            self.policy = make_policy(settings.policy, self.env, settings.device)
        except BaseException:
            self.env.close()
            raise

    def run(self, index: int) -> tuple[EpisodeScore, str | None]:
        """Episode ``index`` (seed ``settings.seed + index``); its score and video path."""
        s, env = self.settings, self.env
        seed = s.seed + index
        obs, info = env.reset(seed=seed)
        self._call_policy(index, "reset", self.policy.reset, env, seed)
        self.recorder.reset()
        frames = [] if index < s.videos else None
        if frames is not None:
            frames.append(env.render())
        rewards, success, fault = [], False, None
        for t in range(env.episode_length):
            action = self._call_policy(index, f"step {t}", self.policy.act, obs)
            check_action(s.policy, action, index, f"step {t}")
            obs, reward, terminated, truncated, info = env.step(action)
            self.recorder.record(env, reward)
            rewards.append(reward)
            success = success or bool(info["is_success"])
            fault = info.get("fault", fault)
            if frames is not None:
                frames.append(env.render())
            if terminated or truncated:
                break
        best = float(max(rewards)) if rewards else 0.0
        analysis = self.recorder.summary(success)
        if fault is not None:
            analysis["fault"] = fault
        if env.randomization is not None:  # what the scene was randomized by
            analysis["randomization"] = env.randomization
        if "base_clipped" in info:  # a Mobile AI base: its commands clipped to its limits
            analysis["base_clipped_commands"] = int(info["base_clipped"])
        score = EpisodeScore(
            episode_ix=index,
            seed=seed,
            sum_reward=float(sum(rewards)),
            max_reward=best,
            success=success,
            steps=len(rewards),
            stages=stages_reached(env.task_name, best),
            fault=fault,
            peak_speed_fraction=env.controller.peak_fractions(),
            analysis=analysis,
        )
        video = None
        if frames:
            from trossen_arm_mujoco.data.video import write_frames_video

            path = Path(s.output_dir) / VIDEO_DIR / f"eval_episode_{index}.mp4"
            h, w = frames[0].shape[:2]
            even = [np.pad(f, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge") for f in frames]
            video = str(write_frames_video(even, path, env.fps, h + h % 2, w + w % 2))
        return score, video

    def _call_policy(self, index: int, when: str, fn: Callable[..., Any], *args: Any) -> Any:
        """``fn(*args)``; an exception of the policy's own (not a UserError) becomes a
        ``PolicyCallError`` naming the policy, the episode and ``when``."""
        try:
            return fn(*args)
        except UserError:
            raise
        except Exception as exc:
            raise PolicyCallError(
                f"the policy {self.settings.policy} raised {type(exc).__name__} at episode "
                f"{index} {when}: {exc}"
            ) from exc

    def close(self) -> None:
        """Close the policy and the env."""
        self.policy.close()
        self.env.close()


# -- local worker processes -------------------------------------------------------------
@contextmanager
def _torch_threads_kept() -> Iterator[None]:
    """This process's torch intra-op thread count as it was before the block (torch's
    default for the restored environment when the block imported torch): the caller runs
    episodes as one of the workers, with a worker's share of the cores."""
    before = sys.modules["torch"].get_num_threads() if "torch" in sys.modules else None
    try:
        yield
    finally:
        if "torch" in sys.modules:
            default = int(os.environ.get("OMP_NUM_THREADS") or available_cpus())
            sys.modules["torch"].set_num_threads(before or default)


def _local(settings: EvalSettings, workers: int) -> Iterator[tuple[EpisodeScore, str | None]]:
    if workers <= 1:
        runner = EpisodeRunner(settings)
        try:
            for i in range(settings.num_episodes):
                yield runner.run(i)
        finally:
            runner.close()
        return
    threads = threads_per_worker(workers)
    pool = WorkerPool(
        workers - 1,
        partial(EpisodeRunner, settings, threads),
        describe=lambda index: f"episode {index}",
        advice=WORKERS_DIED_ADVICE,
    )
    with _torch_threads_kept(), thread_env(threads):  # the spawned workers inherit it
        try:
            for _, result in in_order(pool.results(range(settings.num_episodes), here=True)):
                yield result
        finally:
            pool.shutdown()


def _ray(settings: EvalSettings, workers: int) -> Iterator[tuple[EpisodeScore, str | None]]:
    from trossen_arm_mujoco.collect.ray_session import ray_session

    with ray_session(num_cpus=max(workers, 1)) as ray:
        actor_cls = ray.remote(num_cpus=1)(EpisodeRunner)
        threads = threads_per_worker(workers)
        actors = [actor_cls.remote(settings, threads) for _ in range(max(1, workers))]
        refs = [actors[i % len(actors)].run.remote(i) for i in range(settings.num_episodes)]
        for ref in refs:
            yield ray.get(ref)


ENGINES: dict[str, Callable[[EvalSettings, int], Iterator[tuple[EpisodeScore, str | None]]]] = {
    "local": _local,
    "ray": _ray,
}


def evaluate(
    settings: EvalSettings,
    num_workers: int = 1,
    engine: str = "local",
    on_episode: Callable[[EpisodeScore], None] | None = None,
) -> dict[str, Any]:
    """Run the evaluation; returns the ``eval_info.json`` content (not written here).

    ``on_episode`` is called with each episode's score as it arrives (a progress bar).

    Args:
        settings: what every episode shares (task, policy, seeds, cameras, rate, layout).
        num_workers: worker processes (this one included with ``local``).
        engine: ``local`` or ``ray``.
        on_episode: called with each episode's score as it arrives.

    Raises:
        UserError: an unknown engine, or a worker's one-line error.
    """
    if engine not in ENGINES:
        from trossen_arm_mujoco.errors import unknown_name_error

        raise unknown_name_error("engine", engine, ENGINES)
    start = time.perf_counter()
    scores: list[EpisodeScore] = []
    videos: list[str] = []
    for score, video in ENGINES[engine](settings, num_workers):
        scores.append(score)
        if video:
            videos.append(video)
        if on_episode is not None:
            on_episode(score)
    run = settings.run_block()
    run.update(num_workers=num_workers, engine=engine)
    return eval_info(settings.task, scores, time.perf_counter() - start, videos, run)
