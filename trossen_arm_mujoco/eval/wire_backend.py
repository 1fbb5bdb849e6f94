"""``eval --backend wire``: a policy driven through the served kit, in wall-clock time.

The rehearsal of a deployment: the policy (``eval.policies.make_policy``) reads the joints
through the ``trossen_arm`` driver and the images from the kit's ZeroMQ camera stream, and
sends its actions through the driver at its own rate by the wall clock, while the served kit
(``serve``, started here or already running) steps in real time and scores the episode.
Episode ``i`` is the scene of the in-process eval's ``env.reset(seed=S + i)``. Per episode it
measures observation age and action latency (ms) and missed control periods; an episode
fails on an action timeout, a stale camera stream or an arm fault.

Docs: docs/rehearsal.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval.action_check import check_action
from trossen_arm_mujoco.eval.prepare import carries_images
from trossen_arm_mujoco.eval.runner import EvalSettings, PolicyCallError
from trossen_arm_mujoco.eval.scores import STAGES, EpisodeScore, eval_info, stages_reached
from trossen_arm_mujoco.eval.speed_clamp import KIT_SPEED_LIMITS, SpeedClamp
from trossen_arm_mujoco.eval.wire_env import WireEnv
from trossen_arm_mujoco.eval.wire_link import (
    ArmPair,
    CameraReader,
    ControlClient,
    KitLink,
    start_kit,
    stop_kit,
)
from trossen_arm_mujoco.real.arm_controller import ARM_SIDES, SIDES, KitController
from trossen_arm_mujoco.real.controller_checks import fault_from_message
from trossen_arm_mujoco.sim.camera_crop import FRAME, crop_frame

__all__ = ["WireEpisodeRunner", "evaluate_wire"]

#: A camera whose newest image is older than this (s) has stopped: the episode fails.
STALE_S = 2.0
#: Seconds to wait for the first images of an episode's new scene.
FIRST_IMAGE_S = 10.0
#: Each command's goal time in control periods, as ``replay-real`` streams
#: (``real.replay.ReplayConfig.goal_time_factor``).
GOAL_TIME_FACTOR = 3.0
#: Seconds a policy's reset may take (before the kit's episode starts: no control period).
RESET_TIMEOUT_S = 120.0


class _PolicyThread:
    """Calls the policy in a daemon thread, so that a policy that stops answering is
    reported after a timeout instead of hanging the evaluation."""

    def __init__(self) -> None:
        self._jobs: queue.Queue = queue.Queue()
        self.busy = threading.Event()
        threading.Thread(target=self._work, name="wire-policy", daemon=True).start()

    def _work(self) -> None:
        while True:
            fn, args, box, done = self._jobs.get()
            try:
                box.append((True, fn(*args)))
            except BaseException as exc:  # handed to the caller
                box.append((False, exc))
            self.busy.clear()
            done.set()

    def call(self, timeout: float, fn: Callable[..., Any], *args: Any) -> tuple[bool, Any]:
        """``(True, result)``; ``(False, exc)`` when it raised; TimeoutError after
        ``timeout`` s (the call goes on in the thread: :attr:`busy` stays set)."""
        box: list = []
        done = threading.Event()
        self.busy.set()
        self._jobs.put((fn, args, box, done))
        if not done.wait(timeout):
            raise TimeoutError
        return box[0]


@dataclass
class _Timing:
    obs_age: list[float]
    latency: list[float]
    missed: int = 0
    shortened: int | None = None

    def summary(self) -> dict[str, Any]:
        def q(values: list[float], p: float) -> float | None:
            return round(float(np.quantile(values, p)) * 1e3, 3) if values else None

        return {
            "obs_age_ms": {"median": q(self.obs_age, 0.5), "p95": q(self.obs_age, 0.95)},
            "action_latency_ms": {"median": q(self.latency, 0.5), "p95": q(self.latency, 0.95)},
            "missed_periods": self.missed,
            "actions": len(self.latency),
            "shortened_goals": self.shortened,
        }


class WireEpisodeRunner:
    """The served kit (started unless ``link.connect``), its links, and the policy; runs
    episodes by index like ``runner.EpisodeRunner``.

    Args:
        settings: what every episode shares (as ``runner.evaluate``).
        link: the served kit's addresses and ports.
        action_timeout: seconds without an action from the policy before the episode fails.
        speed_fraction: shorten each goal to this share of the real speed limits
            (``eval.speed_clamp``); None: goals as sent.
    """

    def __init__(
        self,
        settings: EvalSettings,
        link: KitLink,
        action_timeout: float,
        speed_fraction: float | None = None,
    ) -> None:
        from trossen_arm_mujoco.eval.policies import make_policy

        self.settings, self.link, self.action_timeout = settings, link.checked(), action_timeout
        self.speed_fraction = speed_fraction
        self._measured: np.ndarray | None = None
        self.env = WireEnv(settings)
        # cropped cameras: the kit streams whole frames, as real cameras do; a checkpoint
        # prepared with its image step cuts them itself, any other policy gets each crop cut
        # out here (sim.camera_crop.crop_frame), as a deployed policy's would be
        self.stream_size = FRAME if settings.cameras.crops else tuple(self.env.image_size)
        self.whole_frames = carries_images(settings.policy)
        self.period = 1.0 / self.env.fps
        self.kit = self.control = self.cameras = self.arms = self.policy = None
        self.kit_lines: list[str] = []
        try:
            if not link.connect:
                self.kit = start_kit(
                    link, self.env.task_name, self.env.cam_names, self.stream_size, self.env.fps
                )
            self.control = ControlClient(link.host, link.control_port)
            if self.env.cam_names:
                self.cameras = CameraReader(link.host, link.camera_port)
            # a single arm's task: its one arm on the left arm's address
            self.arms = ArmPair(link.left_ip, None if self.env.single_arm else link.right_ip)
            self.policy = make_policy(settings.policy, self.env, settings.device)
        except BaseException:
            self.close()
            raise
        self.calls = _PolicyThread()

    def _observe(
        self, status: dict[str, Any], pos: np.ndarray, vel: np.ndarray
    ) -> tuple[dict[str, Any], float, str | None]:
        """The observation of the arms' ``pos`` (rad, m) and ``vel`` (rad/s, m/s) just read,
        the kit's ``status`` and the newest images; the time of the state it shows (wall
        clock, s); why it is unusable (None)."""
        self._measured = np.asarray(pos, dtype=np.float64)
        stamp = time.time()
        obs: dict[str, Any] = {
            "agent_pos": self.env.to_layout(pos),
            "velocity": self.env.to_layout(vel),
            "environment_state": np.asarray(status["env_state"], dtype=np.float32),
        }
        goal = self.env.goal()
        if goal is not None:  # a single arm's goal, as the in-process env observes it
            obs["goal"] = goal.astype(np.float32)
            obs["environment_state"] = np.r_[obs["environment_state"], obs["goal"]]
        if self.cameras is None:
            return obs, stamp, None
        frames, pixels = self.cameras.frames(), {}
        for cam in self.env.cam_names:
            if cam not in frames:
                return obs, stamp, f"camera {cam} is not on the stream"
            img, t = frames[cam]
            if stamp - t > STALE_S:
                why = f"camera stream stopped ({cam}: newest image {stamp - t:.1f} s old)"
                return obs, stamp, why
            if img.shape[:2] != tuple(self.stream_size):
                raise UserError(
                    f"the stream's {cam} images are {img.shape[0]}x{img.shape[1]}, "
                    f"the policy needs {self.stream_size[0]}x"
                    f"{self.stream_size[1]}: serve --image_size"
                )
            pixels[cam] = (
                img
                if self.whole_frames
                else crop_frame(img, self.settings.cameras.crop_of(cam), self.env.image_size)
            )
            stamp = min(stamp, t)
        obs["pixels"] = pixels
        return obs, stamp, None

    def run(self, index: int) -> tuple[EpisodeScore, None]:
        """Episode ``index`` (seed ``settings.seed + index``): its score (no video)."""
        if not _wait_clear(self.calls.busy, self.action_timeout):
            raise UserError(
                f"the policy {self.settings.policy} has not answered for more than "
                f"{self.action_timeout:g} s; stopped before episode {index}"
            )
        seed = self.settings.seed + index
        scene = self.env.draw_scene(seed)
        # before the kit's episode starts: a plan made here (scripted) costs no control time
        self._call(index, "reset", self.policy.reset, self.env, seed, timeout=RESET_TIMEOUT_S)
        self.arms.close()  # the old sessions stop streaming before the scene is reset
        began = time.time()
        self.control.request("start", seed=seed, **scene)  # the in-process eval's scene
        # the kit put the arms at the initial pose: new driver sessions start from there
        # (a driver interpolates from its last goal) and clear any error state
        self.arms.connect()
        if self.cameras is not None and not self.cameras.wait_newer(
            self.env.cam_names, began, FIRST_IMAGE_S
        ):
            raise UserError(
                f"no image of the new scene on the camera stream within "
                f"{FIRST_IMAGE_S:g} s (is serve --cameras running?)"
            )
        timing, rewards, failure, fault = _Timing([], []), [], None, None
        # the speeds asked, as the driver's trajectory makes them (nothing refused here: the
        # served kit is the controller)
        single = self.env.single_arm
        sides = ARM_SIDES if single else SIDES
        shadow, last_command = KitController(checks=False, sides=sides), None
        limits = KIT_SPEED_LIMITS[:7] if single else None
        clamp = SpeedClamp(self.speed_fraction, limits) if self.speed_fraction else None
        t0 = time.monotonic()
        for k in range(self.env.episode_length):
            deadline = t0 + k * self.period
            now = time.monotonic()
            if now > deadline + self.period:  # this period's deadline passed: skipped
                timing.missed += 1
                continue
            time.sleep(max(0.0, deadline - now))
            start = time.monotonic()
            status = self.control.request("status")
            rewards.append(float(status["reward"]))
            try:  # only the arms' own calls: their errors are the controller's faults
                pos, vel = self.arms.read()
            except self.arms.errors as exc:
                failure, fault = _arm_fault(k, exc)
                break
            obs, stamp, failure = self._observe(status, pos, vel)
            if failure is not None:
                break
            try:  # the policy's own errors end the run (PolicyCallError), as eval --backend sim
                action = self._call(index, f"step {k}", self.policy.act, obs)
            except TimeoutError:
                failure = f"the policy sent no action for {self.action_timeout:g} s (step {k})"
                break
            check_action(self.settings.policy, action, index, f"step {k}")  # as --backend sim
            goal, goal_time = self.env.to_driver(action), GOAL_TIME_FACTOR * self.period
            if clamp is not None:
                goal = clamp(goal, self._measured, goal_time)
            now = time.monotonic()
            if last_command is None:
                shadow.reset(self._measured)
            else:
                shadow.tick(now - last_command)
            shadow.command(goal, goal_time)
            shadow.tick(0.0)
            last_command = now
            try:
                self.arms.command(goal, goal_time)
            except self.arms.errors as exc:
                failure, fault = _arm_fault(k, exc)
                break
            timing.latency.append(time.monotonic() - start)
            timing.obs_age.append(time.time() - stamp)
        end = self.control.request("end")
        timing.shortened = None if clamp is None else clamp.shortened
        score = self._score(index, seed, end, rewards, timing, failure, fault)
        score.peak_speed_fraction = shadow.peak_fractions()
        return score, None

    def _call(
        self, index: int, when: str, fn: Callable[..., Any], *args: Any, timeout: float = 0.0
    ) -> Any:
        """``fn(*args)`` in the policy thread, waiting ``timeout`` s (default the action
        timeout); the policy's own exception becomes a ``PolicyCallError``."""
        try:
            ok, value = self.calls.call(timeout or self.action_timeout, fn, *args)
        except TimeoutError:
            if when != "reset":
                raise
            raise UserError(
                f"the policy {self.settings.policy} did not reset within "
                f"{timeout:g} s (episode {index})"
            ) from None
        if ok:
            return value
        if isinstance(value, UserError):
            raise value
        raise PolicyCallError(
            f"the policy {self.settings.policy} raised {type(value).__name__} "
            f"at episode {index} {when}: {value}"
        ) from value

    def _score(self, index, seed, end, rewards, timing, failure, fault=None) -> EpisodeScore:
        task_name = self.env.task_name
        names = {str(int(level)): name for name, level in STAGES.get(task_name, {}).items()}
        times = {names[lv]: t for lv, t in end["stages"].items() if lv in names}
        stage_times = {name: times.get(name) for name in STAGES.get(task_name, {})}
        success = bool(end["success"]) and failure is None
        analysis: dict[str, Any] = {"stage_times_s": stage_times, "timing": timing.summary()}
        if end.get("randomization") is not None:  # what the served scene was randomized by
            analysis["randomization"] = end["randomization"]
        if not success:
            from trossen_arm_mujoco.eval.rollout_analysis import stopped_at

            analysis["stopped"] = stopped_at(task_name, stage_times)
            analysis["failure"] = failure
        best = float(end["max_reward"])
        return EpisodeScore(
            episode_ix=index,
            seed=seed,
            sum_reward=float(sum(rewards)),
            max_reward=best,
            success=success,
            steps=len(timing.latency),
            stages=stages_reached(task_name, best),
            fault=fault,
            analysis=analysis,
        )

    def close(self) -> None:
        """Close the policy, the driver connections, the camera reader and the control
        channel (errors ignored), then stop the kit this runner started (if any)."""
        for part in (self.policy, self.arms, self.cameras, self.control):
            if part is not None:
                try:
                    part.close()
                except Exception:
                    pass
        self.kit_lines = stop_kit(self.kit)
        self.kit = None
        self.env.close()


def _arm_fault(step: int, exc: BaseException) -> tuple[str, dict[str, Any]]:
    """The failure line of an arm controller in its error state (a driver call raised), and
    the fault as ``eval_info.json`` counts it (joint, kind, asked, limit read back from the
    controller's log; ``step``: the control period at which the driver reported it, one
    after the command that caused it)."""
    fault = fault_from_message(str(exc), getattr(exc, "side", ""))
    fault["step"] = step
    return f"arm controller error at step {step}: {' '.join(str(exc).split())}", fault


def _wait_clear(event: threading.Event, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while event.is_set() and time.monotonic() < deadline:
        time.sleep(0.01)
    return not event.is_set()


def evaluate_wire(
    settings: EvalSettings,
    link: KitLink,
    action_timeout: float = 2.0,
    on_episode: Callable[[EpisodeScore], None] | None = None,
    speed_fraction: float | None = None,
) -> dict[str, Any]:
    """Run the evaluation through the served kit; returns ``eval_info.json``'s content
    (as ``runner.evaluate``) with a ``timing`` block: per episode and over all actions
    (observation age and action latency, median and p95 ms; missed control periods; goals
    shortened to ``speed_fraction`` of the speed limits, None when not asked).

    Args:
        settings: what every episode shares (as ``runner.evaluate``).
        link: the served kit's addresses and ports.
        action_timeout: seconds without an action from the policy before the episode fails.
        on_episode: called with each episode's score as it arrives.
        speed_fraction: shorten each goal to this share of the real speed limits; None: goals as
            sent.
    """
    start = time.perf_counter()
    runner = WireEpisodeRunner(settings, link, action_timeout, speed_fraction)
    scores: list[EpisodeScore] = []
    try:
        for i in range(settings.num_episodes):
            score, _ = runner.run(i)
            scores.append(score)
            if on_episode is not None:
                on_episode(score)
    finally:
        runner.close()
    run = settings.run_block()
    run.update(
        num_workers=1,
        engine="local",
        backend="wire",
        kit=asdict(link),
        action_timeout=action_timeout,
        speed_fraction=speed_fraction,
    )
    info = eval_info(settings.task, scores, time.perf_counter() - start, (), run)
    per = [s.analysis["timing"] for s in scores]
    info["timing"] = {
        "per_episode": per,
        "missed_periods": sum(p["missed_periods"] for p in per),
        "actions": sum(p["actions"] for p in per),
        "obs_age_ms_median_of_episodes": _median([p["obs_age_ms"]["median"] for p in per]),
        "action_latency_ms_median_of_episodes": _median(
            [p["action_latency_ms"]["median"] for p in per]
        ),
        "failures": {
            s.episode_ix: s.analysis.get("failure") for s in scores if s.analysis.get("failure")
        },
        # the kit's own report when it was started here: camera rate and frame age, its
        # real-time factor
        "kit": [line for line in runner.kit_lines if line.startswith(("cameras:", "stopped"))],
    }
    return info


def _median(values: list[float | None]) -> float | None:
    kept = [v for v in values if v is not None]
    return float(np.median(kept)) if kept else None
