"""What happened in each evaluation rollout: when each stage was reached and what the grippers
were doing, written as ``rollouts.json`` next to ``eval_info.json``.

A :class:`RolloutRecorder` is fed the env after every step of an episode (``EpisodeRunner``
does it) and reads the running task: its reward, its contact check and the grippers' finger
opening (m). Step ``k`` is the state after the policy's ``k``-th action, ``(k + 1) / fps`` s
after the reset. :meth:`RolloutRecorder.summary` gives one episode's record,
:func:`rollouts_report` the aggregate over episodes.

Docs: docs/cli/eval.md; the record's fields: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import statistics
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.eval.scores import STAGES, EpisodeScore, write_json

__all__ = [
    "LIFT_STAGE",
    "RELEASE_OPENING",
    "ROLLOUTS_FILE",
    "RolloutRecorder",
    "failure_line",
    "rollouts_report",
    "stopped_at",
    "write_rollouts",
]

#: The file written next to ``eval_info.json``.
ROLLOUTS_FILE = "rollouts.json"
#: Opening (m) by which the right fingers must widen beyond their narrowest since the lift
#: for a release to count (contact jitter on a held cube stays well below it).
RELEASE_OPENING = 0.002
#: The stage after which a release is looked for (transfer: the cube off the table).
LIFT_STAGE = "lifted"


class RolloutRecorder:
    """Per-step record of one episode of ``task_name`` at ``fps`` steps/s (see the module doc)."""

    def __init__(self, task_name: str, fps: float):
        self.task_name = task_name
        self.fps = float(fps)
        self.stages = STAGES.get(task_name, {})
        self.reset()

    def reset(self) -> None:
        """Forget the last episode (call after ``env.reset``)."""
        self.rewards: list[float] = []
        self.gaps: list[tuple[float, float]] = []  # (left, right) finger opening, m
        self.left_touch: list[bool] = []
        self._readers: tuple[Any, Any, Any, Any] | None = None  # looked up once an episode
        self.one_gripper = False  # a single arm's env (its gripper read as both)

    def record(self, env: Any, reward: float) -> None:
        """Read the state after one ``env.step`` (``env``: a ``KitPolicyEnv``; ``reward``: the
        step's reward)."""
        if self._readers is None and getattr(env, "arms", 2) == 1:  # one arm, one gripper
            task = env.task
            gripper = task.robot.view.get_move_group("gripper")
            self._readers = (gripper, gripper, lambda: False, task.data)
            self.one_gripper = True
        if self._readers is None:  # the episode's grippers and contact check, found once
            task = env.task
            view = task.robot.view
            self._readers = (
                view.get_move_group("left_gripper"),
                view.get_move_group("right_gripper"),
                task.left_touches_object,  # the task's own contact check
                task.data,
            )
        left, right, touching, _ = self._readers
        self.rewards.append(float(reward))
        self.gaps.append((left.inter_finger_dist, right.inter_finger_dist))
        self.left_touch.append(bool(touching()))

    def _time(self, step: int | None) -> float | None:
        return None if step is None else round((step + 1) / self.fps, 6)

    def stage_steps(self) -> dict[str, int | None]:
        """Stage -> the first step whose reward reached its level, or None."""
        r = np.asarray(self.rewards)
        out: dict[str, int | None] = {}
        for name, level in self.stages.items():
            hits = np.flatnonzero(r >= level)
            out[name] = int(hits[0]) if hits.size else None
        return out

    def release_step(self, lift_step: int | None) -> int | None:
        """The step at which the right fingers began opening after ``lift_step``: the start of
        the first widening by more than ``RELEASE_OPENING`` beyond their narrowest since the
        lift; None when there is none."""
        if lift_step is None:
            return None
        right = np.asarray([g[1] for g in self.gaps])
        narrowest = right[lift_step]
        for k in range(lift_step, len(right)):
            narrowest = min(narrowest, right[k])
            if right[k] > narrowest + RELEASE_OPENING:
                start = k
                while start > lift_step and right[start - 1] < right[start] - 1e-6:
                    start -= 1
                return start
        return None

    def summary(self, success: bool) -> dict[str, Any]:
        """This episode's analysis (a JSON-ready dict, see the module doc)."""
        steps = self.stage_steps()
        out: dict[str, Any] = {
            "stage_steps": steps,
            "stage_times_s": {k: self._time(v) for k, v in steps.items()},
            "stopped": None if success else stopped_at(self.task_name, steps),
        }
        if LIFT_STAGE in steps:
            k = self.release_step(steps[LIFT_STAGE])
            out["release"] = (
                None
                if k is None
                else {
                    "step": k,
                    "time_s": self._time(k),
                    "left_gap_m": round(self.gaps[k][0], 6),
                    "right_gap_m": round(self.gaps[k][1], 6),
                    "left_touching": self.left_touch[k],
                }
            )
        elif self.one_gripper:
            gap = self.gaps[-1][0] if self.gaps else None
            out["end"] = {"gripper_gap_m": None if gap is None else round(gap, 6)}
        else:
            left, right = self.gaps[-1] if self.gaps else (None, None)
            out["end"] = {
                "left_gap_m": None if left is None else round(left, 6),
                "right_gap_m": None if right is None else round(right, 6),
            }
        return out


def stopped_at(task: str, stage_steps: dict[str, int | None]) -> dict[str, str | None]:
    """Where a failed episode stopped: ``reached`` its furthest stage (None: none) and
    ``missed`` the next one (None when it reached them all)."""
    reached, missed = None, None
    for name in STAGES.get(task, {}):
        if stage_steps.get(name) is not None:
            reached = name
        else:
            missed = name
            break
    return {"reached": reached, "missed": missed}


def _median(values: list[float]) -> float | None:
    return round(float(statistics.median(values)), 6) if values else None


def rollouts_report(task: str, scores: Sequence[EpisodeScore], fps: float) -> dict[str, Any]:
    """The content of ``rollouts.json``: each episode's analysis (``EpisodeScore.analysis``)
    and the aggregate (failed episodes by the furthest stage reached; the median left-finger
    gap at release, m, of failed and successful episodes).

    Args:
        task: the task's registered name (its stages).
        scores: the episodes' scores, each with its ``analysis``.
        fps: the policy rate (Hz).
    """
    failed: dict[str, int] = {}
    faults: dict[str, int] = {}
    gaps: dict[str, list[float]] = {"failed": [], "succeeded": []}
    episodes = []
    for s in scores:
        a = s.analysis or {}
        episodes.append({"episode_ix": s.episode_ix, "seed": s.seed, "success": s.success, **a})
        if not s.success:
            reached = (a.get("stopped") or {}).get("reached") or "none"
            failed[reached] = failed.get(reached, 0) + 1
        if s.fault:
            key = f"{s.fault['joint']} {s.fault['kind']}"
            faults[key] = faults.get(key, 0) + 1
        release = a.get("release")
        if release:
            gaps["succeeded" if s.success else "failed"].append(release["left_gap_m"])
    order = ["none", *STAGES.get(task, {})]
    aggregated: dict[str, Any] = {
        "n_episodes": len(scores),
        "n_failed": sum(failed.values()),
        "failed_by_stage_reached": {k: failed[k] for k in order if k in failed},
        "controller_faults": dict(sorted(faults.items())),
    }
    if LIFT_STAGE in STAGES.get(task, {}):
        aggregated["median_left_gap_at_release_m"] = {k: _median(v) for k, v in gaps.items()}
    return {"task": task, "fps": float(fps), "aggregated": aggregated, "episodes": episodes}


def failure_line(report: dict[str, Any]) -> str:
    """One line summarizing ``report``'s failures, e.g. ``failed: 2 (reached none 1, lifted
    1)``, with the median left gaps at release when there are any."""
    agg = report["aggregated"]
    if not agg["n_failed"]:
        text = "failed: 0"
    else:
        by = ", ".join(f"{k} {n}" for k, n in agg["failed_by_stage_reached"].items())
        text = f"failed: {agg['n_failed']} (furthest stage reached: {by})"
    faults = agg.get("controller_faults") or {}
    if faults:
        by = ", ".join(f"{k} {n}" for k, n in faults.items())
        text += f"; arm controller faults: {sum(faults.values())} ({by})"
    medians = agg.get("median_left_gap_at_release_m") or {}
    shown = [f"{k} {v * 1e3:.1f} mm" for k, v in medians.items() if v is not None]
    if shown:
        text += "; median left gap at release: " + ", ".join(shown)
    return text


def write_rollouts(path: Path, report: dict[str, Any]) -> Path:
    """Write ``report`` as JSON to ``path`` atomically."""
    return write_json(path, report)
