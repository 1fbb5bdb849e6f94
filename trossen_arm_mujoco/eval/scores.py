"""Scores of an evaluation: per episode, aggregated, stage-wise, with a confidence interval,
written as ``eval_info.json`` in ``lerobot-eval``'s layout.

An episode's success is whether the task judged it a success at any step (LeRobot's rule,
and the ACT paper's); its stages are the reward levels it reached (``STAGES``). The file
holds ``per_episode`` rows (each with its controller ``fault``, or null), ``aggregated``
(with ``pc_success_ci95``), ``overall``, ``video_paths`` and ``controller``.

Docs: docs/cli/eval.md; the file's fields: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from trossen_arm_mujoco.fileio import atomic_path
from trossen_arm_mujoco.tasks import registry

__all__ = [
    "STAGES",
    "EpisodeScore",
    "aggregate",
    "controller_summary",
    "eval_info",
    "stages_reached",
    "wilson_interval",
    "write_eval_info",
    "write_json",
    "write_results",
]


class _Stages(Mapping):
    """Task -> stage name -> the reward that marks it, read from each task's declaration
    (``TaskEntry.stages``); tasks without stages are not listed."""

    def __getitem__(self, task: str) -> dict[str, float]:
        found = registry.stages(task)
        if not found:
            raise KeyError(task)
        return found

    def __iter__(self) -> Iterator[str]:
        return iter([n for n in registry.names() if registry.stages(n)])

    def __len__(self) -> int:
        return len(list(iter(self)))


#: Task -> stage name -> the reward that marks it (reached when max reward >= it).
STAGES: Mapping[str, dict[str, float]] = _Stages()


def wilson_interval(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """95% Wilson score interval of a success rate, in percent (0, 0 for n = 0).

    Args:
        successes: the number of successful episodes.
        n: the number of episodes.
        z: the normal quantile (1.96: 95 %).
    """
    if n <= 0:
        return 0.0, 0.0
    p = successes / n
    denom = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else 100.0 * max(0.0, centre - half)
    hi = 100.0 if successes == n else 100.0 * min(1.0, centre + half)
    return lo, hi


@dataclass
class EpisodeScore:
    """One rollout's result."""

    episode_ix: int
    seed: int
    sum_reward: float
    max_reward: float
    success: bool
    steps: int
    stages: dict[str, bool] = field(default_factory=dict)
    #: The arm controller's fault that ended the episode (``real.controller_checks.Fault.
    #: as_dict()`` plus its ``step``), None when every command was accepted.
    fault: dict[str, Any] | None = None
    #: Largest speed asked of each of the 14 values (``left_joint_0`` ... ``right_gripper``)
    #: as a fraction of its limit; None when not measured.
    peak_speed_fraction: dict[str, float] | None = field(default=None, compare=False)
    #: What happened in the rollout (``eval.rollout_analysis``; ``rollouts.json``, not
    #: ``eval_info.json``); None when not recorded.
    analysis: dict[str, Any] | None = field(default=None, compare=False)


def stages_reached(task: str, max_reward: float) -> dict[str, bool]:
    """Which stages of ``task`` an episode with best reward ``max_reward`` reached."""
    return {name: max_reward >= level for name, level in STAGES.get(task, {}).items()}


def aggregate(task: str, episodes: Sequence[EpisodeScore], seconds: float) -> dict[str, Any]:
    """The ``aggregated`` block of ``eval_info.json``.

    Args:
        task: the task's registered name (its stages).
        episodes: the episodes' scores.
        seconds: the evaluation's wall time (s).
    """
    n = len(episodes)
    wins = sum(e.success for e in episodes)
    lo, hi = wilson_interval(wins, n)

    def mean(values: list[float]) -> float:
        return float(sum(values) / len(values)) if values else float("nan")

    return {
        "avg_sum_reward": mean([e.sum_reward for e in episodes]),
        "avg_max_reward": mean([e.max_reward for e in episodes]),
        "pc_success": 100.0 * wins / n if n else float("nan"),
        "pc_success_ci95": [lo, hi],
        "n_episodes": n,
        "stages": {
            name: 100.0 * sum(e.stages.get(name, False) for e in episodes) / n if n else 0.0
            for name in STAGES.get(task, {})
        },
        "eval_s": float(seconds),
        "eval_ep_s": float(seconds) / max(1, n),
    }


def controller_summary(episodes: Sequence[EpisodeScore], checks: bool) -> dict[str, Any]:
    """The ``controller`` block of ``eval_info.json``: whether the arm controller's checks
    were on, how many episodes faulted, counted by joint and by reason (``speed``,
    ``position``, ``non-finite``), and the largest speed asked of each value over all
    episodes as a fraction of its limit."""
    faults = [e.fault for e in episodes if e.fault]
    by_joint: dict[str, int] = {}
    by_reason: dict[str, int] = {}
    for f in faults:
        by_joint[f["joint"]] = by_joint.get(f["joint"], 0) + 1
        by_reason[f["kind"]] = by_reason.get(f["kind"], 0) + 1
    peak: dict[str, float] = {}
    for e in episodes:
        for key, value in (e.peak_speed_fraction or {}).items():
            peak[key] = max(peak.get(key, 0.0), float(value))
    return {
        "checks": bool(checks),
        "faulted_episodes": len(faults),
        "faults_by_joint": dict(sorted(by_joint.items())),
        "faults_by_reason": dict(sorted(by_reason.items())),
        "peak_speed_fraction": {k: round(v, 4) for k, v in peak.items()},
    }


def eval_info(
    task: str,
    episodes: Sequence[EpisodeScore],
    seconds: float,
    video_paths: Sequence[str] = (),
    run: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The content of ``eval_info.json`` (see the module docstring).

    Args:
        task: the task's registered name (its stages).
        episodes: the episodes' scores.
        seconds: the evaluation's wall time (s).
        video_paths: the rollout videos written.
        run: how the run was made (settings), kept as ``run``; its ``controller_checks`` says
            whether the checks were on.
    """
    agg = aggregate(task, episodes, seconds)
    overall = {
        k: agg[k]
        for k in (
            "avg_sum_reward",
            "avg_max_reward",
            "pc_success",
            "n_episodes",
            "eval_s",
            "eval_ep_s",
        )
    }
    per_episode = []
    for e in episodes:
        row = asdict(e)
        row.pop("analysis", None)  # rollouts.json's; eval_info.json keeps lerobot-eval's keys
        row.pop("peak_speed_fraction", None)  # aggregated in the controller block
        per_episode.append(row)
    checks = bool((run or {}).get("controller_checks", True))
    return {
        "task": task,
        "per_episode": per_episode,
        "aggregated": agg,
        "overall": {**overall, "video_paths": list(video_paths)},
        "video_paths": list(video_paths),
        "controller": controller_summary(episodes, checks),
        **({"run": run} if run else {}),
    }


def write_eval_info(path: Path, info: dict[str, Any]) -> Path:
    """Write ``info`` as JSON to ``path`` atomically (temp file, then rename)."""
    return write_json(path, info)


def write_results(files: dict[Path, dict[str, Any]]) -> list[Path]:
    """Write several JSON results all or none: each to a temporary file first, then all
    published (renames need no space). A full disk (or any OS error while writing) removes
    the temporary files and is one UserError naming the file and the free space; nothing is
    half-written and no earlier result is replaced."""
    import os
    import shutil

    from trossen_arm_mujoco.errors import UserError
    from trossen_arm_mujoco.fileio import publish, temp_path

    staged: list[tuple[Path, Path]] = []
    try:
        for path, info in files.items():
            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = temp_path(path)
            staged.append((tmp, path))
            tmp.write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
        for tmp, path in staged:
            publish(tmp, path, overwrite=True)
    except OSError as exc:
        for tmp, _ in staged:
            tmp.unlink(missing_ok=True)
        where = staged[-1][1] if staged else next(iter(files))
        try:
            free = f"; {shutil.disk_usage(Path(where).parent).free / 1e6:.1f} MB free"
        except OSError:
            free = ""
        why = os.strerror(exc.errno) if exc.errno else str(exc)
        raise UserError(
            f"cannot write {where} ({why}{free}); nothing of this run's results "
            "was written: free some space or choose another --output_dir, then "
            "run it again"
        ) from None
    return [path for _, path in staged]


def write_json(path: Path, info: dict[str, Any]) -> Path:
    """Write ``info`` as indented JSON to ``path`` atomically (temp file, then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
    return path
