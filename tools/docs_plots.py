"""The Benchmarks page's plots, drawn from the measured numbers in
``docs/data/benchmark_curves.json`` (each set says which benchmark measured it, when and
where). Rerun after adding a measurement; the PNGs are committed.

    python tools/docs_plots.py      # writes docs/images/benchmarks/*.png
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "data" / "benchmark_curves.json"
OUT = ROOT / "docs" / "images" / "benchmarks"


def load() -> dict[str, Any]:
    """The measured curves (see the data file's ``source`` / ``measured`` fields)."""
    return json.loads(DATA.read_text(encoding="utf-8"))


def _save(fig: Any, name: str) -> Path:
    """Write a figure as ``OUT/name`` atomically."""
    from trossen_arm_mujoco.fileio import atomic_path

    OUT.mkdir(parents=True, exist_ok=True)
    with atomic_path(OUT / name) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    return OUT / name


def plot_training_success(curves: dict[str, Any]) -> Path:
    """Success (%) against training steps, every run with its 95 % Wilson interval; colour
    by data, marker by device, points of one step count spread sideways to stay readable."""
    import matplotlib.pyplot as plt

    runs = curves["runs"]
    variants = list(dict.fromkeys(r["data"] for r in runs))
    markers = {"CPU": "o", "H100": "s"}
    fig, ax = plt.subplots(figsize=(9.0, 6.0))
    for i, variant in enumerate(variants):
        for device, marker in markers.items():
            mine = [r for r in runs if r["data"] == variant and r["device"] == device]
            if not mine:
                continue
            x = [r["steps"] + (i - len(variants) / 2) * 90 + (r["seed"] - 1000) * 30 for r in mine]
            y = [r["success"] for r in mine]
            low = [r["success"] - float(r["ci"][0]) for r in mine]
            err = [low, [float(r["ci"][1]) - r["success"] for r in mine]]
            ax.errorbar(
                x, y, yerr=err, fmt=marker, color=f"C{i}", capsize=3, label=f"{variant} ({device})"
            )
    steps = sorted({r["steps"] for r in runs})
    ax.set_xticks(steps)
    ax.set_xticklabels([f"{k // 1000}k" for k in steps])
    ax.set_xlim(steps[0] - 1000, steps[-1] + 1000)
    ax.set_ylim(0, 100)
    ax.set_xlabel("training steps")
    ax.set_ylabel("success over 50 episodes (%)")
    ax.set_title("ACT on sim_transfer_cube: success against training steps")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.16), ncol=2)
    fig.tight_layout()
    return _save(fig, "training_success.png")


def plot_camera_loss(runs: list[dict[str, Any]]) -> Path:
    """Training loss against steps of the one-camera runs (one line each, by its label)."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 3.4))
    for curve in runs:
        ax.plot(curve["steps"], curve["loss"], "o-", label=curve["label"])
    ax.set_xlabel("training steps")
    ax.set_ylabel("training loss")
    ax.set_title("ACT, cam_high 96x128, no object pose")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, "camera_run_loss.png")


def plot_recording_cost(cost: dict[str, Any]) -> Path:
    """Seconds to record one episode (both phases and the file, best of the repeats) against
    its length in steps: wall time as points joined by lines, CPU time dashed; one colour per
    setting; a setting whose times are under a tenth of the slowest one's (state only) goes on
    the right-hand axis, so that its line does not lie flat on zero."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.0, 4.2))
    right = ax.twinx()
    slowest = max(p["wall_s"] for s in cost["settings"] for p in s["points"])
    for i, setting in enumerate(cost["settings"]):
        small = max(p["wall_s"] for p in setting["points"]) < slowest / 10
        axis = right if small else ax
        steps = [p["steps"] for p in setting["points"]]
        label = setting["setting"].replace(" compression", "") + (" (right axis)" if small else "")
        axis.plot(
            steps,
            [p["wall_s"] for p in setting["points"]],
            "o-",
            color=f"C{i}",
            label=f"{label}: wall",
        )
        axis.plot(
            steps,
            [p["cpu_s"] for p in setting["points"]],
            "x--",
            color=f"C{i}",
            label=f"{label}: CPU",
        )
    ax.set_xlabel("episode length (steps at 50 Hz)")
    ax.set_ylabel("seconds per episode (left-hand settings)")
    right.set_ylabel("seconds per episode (right-hand settings)")
    ax.set_ylim(bottom=0)
    right.set_ylim(bottom=0)
    ax.set_title("record: cost of one episode against its length")
    ax.grid(alpha=0.3)
    lines = ax.get_legend_handles_labels()
    more = right.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7, loc="upper left")
    fig.tight_layout()
    return _save(fig, "recording_cost.png")


def main() -> int:
    """Draw every plot; prints the files written."""
    import matplotlib

    matplotlib.use("Agg")
    curves = load()
    for path in (
        plot_training_success(curves["training_success"]),
        plot_camera_loss([curves["camera_run_loss"], curves["crop_run_loss"]]),
        plot_recording_cost(curves["recording_cost"]),
    ):
        print(path.relative_to(ROOT))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
