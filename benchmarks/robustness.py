"""A checkpoint's success under scene variation: each evaluation level, each kind alone and
the camera moved by set amounts (docs/benchmarks.md, "Robustness of the camera recipes").

    MUJOCO_GL=egl TROSSEN_LEROBOT_PYTHON=... python benchmarks/robustness.py \\
        --policy outputs/.../pretrained_model --episodes 30 --out robustness_out

Every condition is one ``trossen-mujoco eval`` run (controller checks on, the same
evaluation seeds for every condition, so the scenes differ only by their variation):

- ``nominal``, ``train``, ``hard``: ``eval --randomize LEVEL`` (``tasks.randomization_levels``);
- ``lights``, ``table``, ``cube colour``, ``camera pose``, ``physics`` (friction, masses,
  joint damping, the arms' start): the task's ``train`` ranges of that kind alone, through
  ``--randomization FILE`` with every other kind off;
- ``camera +-X mm``: ``cam_high`` (every camera) moved by up to X mm per axis, not turned;
  ``camera X deg``: turned by up to X degrees about a random axis, not moved.

A condition whose ``eval_info.json`` exists is read, not run again (a rerun resumes). Prints
one markdown row per condition (success with its Wilson 95 % interval, faulted episodes,
wall and CPU seconds) and writes them to ``OUT/robustness.json`` with the date, the commit
and the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import time
from datetime import date
from pathlib import Path

import yaml

from trossen_arm_mujoco.fileio import write_text

#: The randomization kinds, each condition "kind alone" turns on.
KINDS = (
    "lights",
    "table",
    "objects",
    "friction",
    "object_mass",
    "joint_damping",
    "camera",
    "joint_noise",
)
#: Conditions of one kind group alone: label -> the kinds turned on (their train ranges).
ALONE = {
    "lights": ("lights",),
    "table": ("table",),
    "cube colour": ("objects",),
    "camera pose": ("camera",),
    "physics": ("friction", "object_mass", "joint_damping", "joint_noise"),
}
#: The camera offsets swept: per-axis position (m) with no turn, and turns (deg), no move.
CAMERA_MOVES_MM = (5, 10, 20)
CAMERA_TURNS_DEG = (1, 2, 4)


def section_alone(kinds: tuple[str, ...], camera: dict | None = None) -> dict:
    """A ``randomization`` section with only ``kinds`` on (the task's ranges for them, or
    ``camera``'s parameters for the camera)."""
    section: dict = {kind: {"enabled": kind in kinds} for kind in KINDS}
    if camera is not None:
        section["camera"] = {"enabled": True, **camera}
    return {"randomization": section}


def conditions(only: list[str] | None) -> list[tuple[str, list[str], dict | None]]:
    """``(label, eval flags, randomization section or None)`` of every condition, in table
    order; ``only``: the labels to keep."""
    rows: list[tuple[str, list[str], dict | None]] = [
        (level, ["--randomize", level], None) for level in ("nominal", "train", "hard")
    ]
    rows += [(label, [], section_alone(kinds)) for label, kinds in ALONE.items()]
    rows += [
        (f"camera +-{mm} mm", [], section_alone((), {"position": mm / 1000, "orientation_deg": 0}))
        for mm in CAMERA_MOVES_MM
    ]
    rows += [
        (f"camera {deg} deg", [], section_alone((), {"position": 0.0, "orientation_deg": deg}))
        for deg in CAMERA_TURNS_DEG
    ]
    if only:
        unknown = sorted(set(only) - {label for label, _, _ in rows})
        if unknown:
            valid = ", ".join(label for label, _, _ in rows)
            raise SystemExit(f"error: unknown condition(s) {unknown}; valid: {valid}")
        rows = [row for row in rows if row[0] in only]
    return rows


def folder_name(label: str) -> str:
    """A file-system name of a condition's label."""
    return "".join(c if c.isalnum() else "_" for c in label).strip("_")


def run_condition(
    args: argparse.Namespace, label: str, flags: list[str], section: dict | None
) -> dict:
    """Run (or read) one condition; its row of the table."""
    out = args.out / folder_name(label)
    info_path = out / "eval_info.json"
    wall = cpu = None
    if not info_path.is_file():
        out.mkdir(parents=True, exist_ok=True)
        if section is not None:
            write_text(out / "randomization.yaml", yaml.safe_dump(section))
            flags = ["--randomization", str(out / "randomization.yaml")]
        cmd = [
            shutil.which("trossen-mujoco") or "trossen-mujoco",
            "eval",
            "--policy",
            str(args.policy),
            "--num_episodes",
            str(args.episodes),
            "--seed",
            str(args.seed),
            "--num_workers",
            str(args.workers),
            "--output_dir",
            str(out),
            *flags,
        ]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.monotonic()
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        wall = time.monotonic() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        if proc.returncode != 0 or not info_path.is_file():
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or ["(no output)"]
            raise SystemExit(f"error: {label}: eval exited {proc.returncode}: {tail[0]}")
        write_text(out / "cost.json", json.dumps({"wall_s": wall, "cpu_s": cpu}))
    elif (out / "cost.json").is_file():
        cost = json.loads((out / "cost.json").read_text())
        wall, cpu = cost["wall_s"], cost["cpu_s"]
    info = json.loads(info_path.read_text(encoding="utf-8"))
    agg = info["aggregated"]
    faults = (info.get("controller") or {}).get("faulted_episodes", 0)
    return {
        "condition": label,
        "pc_success": agg["pc_success"],
        "ci95": agg["pc_success_ci95"],
        "n_episodes": agg["n_episodes"],
        "faulted_episodes": faults,
        "wall_s": wall,
        "cpu_s": cpu,
    }


def commit() -> str:
    """The checkout's commit (``+dirty`` with uncommitted changes), or ``unknown``."""
    here = Path(__file__).resolve().parent
    try:
        head = subprocess.run(
            ["git", "-C", str(here), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(here), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+dirty" if dirty else "")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--policy",
        required=True,
        help="a prepared LeRobot checkpoint folder ('scripted' or module:function: any "
        "policy eval takes)",
    )
    p.add_argument("--episodes", type=int, default=30, help="episodes per condition")
    p.add_argument("--seed", type=int, default=0, help="first evaluation seed")
    p.add_argument("--workers", type=int, default=2, help="eval's --num_workers")
    p.add_argument("--out", type=Path, default=Path("robustness_out"))
    p.add_argument("--only", nargs="*", default=None, help="condition labels to run")
    args = p.parse_args(argv)
    looks_like_folder = args.policy != "scripted" and ":" not in args.policy
    if looks_like_folder and not (Path(args.policy) / "config.json").is_file():
        raise SystemExit(f"error: {args.policy} is not a LeRobot checkpoint (no config.json)")
    rows = []
    print("| condition | success | 95 % interval | faults | wall s | CPU s |")
    print("|---|---|---|---|---|---|")
    for label, flags, section in conditions(args.only):
        row = run_condition(args, label, flags, section)
        rows.append(row)
        lo, hi = row["ci95"]
        wall = "-" if row["wall_s"] is None else f"{row['wall_s']:.0f}"
        cpu = "-" if row["cpu_s"] is None else f"{row['cpu_s']:.0f}"
        print(
            f"| {label} | {row['pc_success']:.1f} % | {lo:.1f}-{hi:.1f} | "
            f"{row['faulted_episodes']} of {row['n_episodes']} | {wall} | {cpu} |",
            flush=True,
        )
    report = {
        "date": date.today().isoformat(),
        "commit": commit(),
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs, {platform.system()}",
        "policy": str(args.policy),
        "episodes": args.episodes,
        "seed": args.seed,
        "rows": rows,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    write_text(args.out / "robustness.json", json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
