"""What ``trossen-mujoco train`` reports: each run's success with its 95 % Wilson interval,
its faults and largest asked speeds, the spread over the runs, the loss curve of a log, the
whole cost of the loop and where each checkpoint landed.

Docs: docs/cli/train.md, docs/train-eval.md, docs/benchmarks.md ("The whole loop").
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

__all__ = [
    "RUN_FLAGS",
    "alike",
    "cost",
    "losses",
    "print_cost",
    "recipe_flags",
    "report",
    "results",
    "wilson",
]

#: the flags that say where, with which seeds, how fast and how it is scored a run was made:
#: two runs that differ only in these (and in ``eval_*``) learned the same recipe
RUN_FLAGS = frozenset(
    {
        "work_dir",
        "phase",
        "train_seeds",
        "train_seed",
        "train_jobs",
        "train_threads",
        "num_workers",
        "video_backend",
        "save_freq",
        "device",
        "controller_checks",
    }
)


def wilson(successes: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """95 % Wilson interval of a rate, in percent.

    Args:
        successes: the number of successful episodes.
        n: the number of episodes.
        z: the normal quantile (1.96: 95 %).
    """
    if n <= 0:
        return 0.0, 0.0
    p, denom = successes / n, 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    return 100.0 * max(0.0, centre - half), 100.0 * min(1.0, centre + half)


def losses(log: Path) -> list[float]:
    """The ``loss:`` values lerobot-train logged, in order."""
    return [
        float(part.split(":")[1])
        for line in log.read_text(errors="replace").splitlines()
        for part in line.split()
        if part.startswith("loss:")
    ]


def results(path: Path) -> dict:
    """What a summary keeps of one ``eval_info.json``: the score with the controller's checks
    (``result``), without them (``unconstrained``, when run), the controller block (faults,
    largest asked speeds) and whether the policy deploys."""
    info = json.loads(path.read_text(encoding="utf-8"))
    out = {
        "result": info["aggregated"],
        "controller": info.get("controller"),
        "deployment": info.get("deployment"),
    }
    if "unconstrained" in info:
        out["unconstrained"] = info["unconstrained"]["aggregated"]
    run = info.get("run") or {}
    out["scored_on"] = {k: run.get(k) for k in ("task", "num_episodes", "seed", "episode_length")}
    if run.get("randomize"):  # scenes randomized: at which level (nominal runs say nothing)
        out["scored_on"].update(randomize=True, randomization=run.get("randomization"))
    if "timing" in info:
        out["timing"] = {
            k: info["timing"].get(k)
            for k in (
                "missed_periods",
                "actions",
                "obs_age_ms_median_of_episodes",
                "action_latency_ms_median_of_episodes",
            )
        }
    return out


def recipe_flags(args: dict) -> dict:
    """The flags of ``args`` (``trossen-mujoco train``'s, as a dict) that shape what a run learns:
    all but ``RUN_FLAGS`` and the ``eval_*`` ones."""
    return {k: v for k, v in args.items() if k not in RUN_FLAGS and not k.startswith("eval_")}


def _alike_key(run: dict) -> str | None:
    made, scored = run.get("trained_with"), run.get("scored_on")
    if not run.get("result") or made is None or scored is None:
        return None
    return json.dumps([made, scored], sort_keys=True)


def alike(runs: dict[str, dict], seeds: list[str]) -> dict[str, dict]:
    """The scored runs of ``runs`` (a summary's, by training seed) that were trained with the
    same recipe flags (``trained_with``) and scored on the same episodes (``scored_on``) as
    the runs ``seeds``; none when those differ among themselves or were made before the
    summary kept both."""
    keys = {_alike_key(runs[s]) for s in seeds if runs.get(s, {}).get("result")}
    if len(keys) != 1 or None in keys:
        return {}
    key = keys.pop()
    return {s: run for s, run in runs.items() if _alike_key(run) == key}


def _training(train: dict) -> str:
    """A run's training cost: CPU seconds (and minutes) and steps per second of wall time."""
    cpu = train.get("cpu_s")
    if cpu is None:
        return "training not measured here"
    rate = train.get("steps_per_s")
    steps = f", {rate:.2f} steps/s" if rate else ""
    return f"train {cpu:.0f} s CPU ({cpu / 60:.1f} min){steps}"


def report(runs: dict[str, dict], label: str = "in-process", each: bool = True) -> dict:
    """Each run's success and interval, faults and largest asked speed (printed when
    ``each``), the mean and the worst (printed and returned).

    Args:
        runs: training seed -> that run's summary entry (``result``, ``controller``,
            ``unconstrained``, ``train``).
        label: what the scores are of, for the lines (``in-process``, ``wire``).
        each: print each run's line too.
    """
    rates, total, n = [], 0, 0
    for seed, run in sorted(runs.items(), key=lambda kv: int(kv[0])):
        res = run.get("result")
        if not res:
            continue
        lo, hi = res["pc_success_ci95"]
        ctl = run.get("controller") or {}
        peak = ctl.get("peak_speed_fraction") or {}
        top = max(peak.items(), key=lambda kv: kv[1]) if peak else ("none", 0.0)
        free = run.get("unconstrained")
        freely = f"; checks off {free['pc_success']:.1f}%" if free else ""
        if each:
            print(
                f"training seed {seed} ({label}): success {res['pc_success']:.1f}% (95% CI "
                f"{lo:.1f}-{hi:.1f}) over {res['n_episodes']} episodes{freely}; faults "
                f"{ctl.get('faulted_episodes', 'n/a')}; fastest asked {top[0]} at "
                f"{top[1]:.2f} of its limit; stages {res['stages']}; "
                f"{_training(run.get('train') or {})}"
            )
        rates.append(res["pc_success"])
        total += round(res["pc_success"] * res["n_episodes"] / 100.0)
        n += res["n_episodes"]
    if not rates:
        return {}
    spread = {
        "runs": len(rates),
        "mean_pc_success": sum(rates) / len(rates),
        "worst_pc_success": min(rates),
        "best_pc_success": max(rates),
        "pooled_pc_success_ci95": list(wilson(total, n)),
    }
    lo, hi = spread["pooled_pc_success_ci95"]
    print(
        f"over {len(rates)} training runs ({label}): mean {spread['mean_pc_success']:.1f}%, "
        f"worst {spread['worst_pc_success']:.1f}%, best {spread['best_pc_success']:.1f}% "
        f"(all {n} episodes pooled: 95% CI {lo:.1f}-{hi:.1f})"
    )
    return spread


#: The phases whose cost is printed, and the summary entries each sums.
COST_PARTS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    # name: (entries of the summary, entries of each run)
    "record": (("record", "record_static", "export"), ()),
    "encode": (("encode",), ()),
    "train": ((), ("train",)),
    "evaluate": ((), ("eval", "wire_eval")),
}


def cost(summary: dict[str, Any], seeds: list[str]) -> dict[str, dict[str, float]]:
    """Wall and CPU seconds of each part of the loop as measured in ``summary`` (record with
    the export and the static frames, encode, train and evaluate of the runs ``seeds``);
    a part never measured is left out."""
    out = {}
    for part, (top, per_run) in COST_PARTS.items():
        took = [summary.get(k) for k in top]
        took += [summary.get("runs", {}).get(s, {}).get(k) for s in seeds for k in per_run]
        took = [t for t in took if isinstance(t, dict) and "wall_s" in t]
        if took:
            out[part] = {
                "wall_s": round(sum(t.get("wall_s") or 0.0 for t in took), 1),
                "cpu_s": round(sum(t.get("cpu_s") or 0.0 for t in took), 1),
            }
    return out


def print_cost(parts: dict[str, dict[str, float]]) -> None:
    """One line: each part's wall and CPU seconds (``not measured here`` for the others)."""
    said = []
    for part in COST_PARTS:
        took = parts.get(part)
        said.append(
            f"{part} {took['wall_s']:.0f} s wall, {took['cpu_s']:.0f} s CPU"
            if took
            else f"{part} not measured here"
        )
    print("cost: " + "; ".join(said))
