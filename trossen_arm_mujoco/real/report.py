"""Tracking-error log of a replay and the files written from it.

Per replay, in ``<data folder>/replay/`` (or ``--output_dir``), checked before any arm moves
(:func:`check_outputs`): ``episode_<k>_<backend>_tracking.csv`` (one row per streamed step:
``step``, ``time_s``, then ``cmd_*`` and ``meas_*`` per arm and driver value; rad, gripper
m), ``episode_<k>_<backend>_summary.json`` (RMS and max of measured - commanded per joint,
plus run metadata) and ``episode_<k>_<backend>_tracking.png`` (one panel per joint). Files
are written to a temporary name and renamed; a rerun of the same episode and backend
replaces them.

Docs: docs/cli/replay-real.md.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.errors import UserError, describe_os_error, os_error_hint
from trossen_arm_mujoco.fileio import atomic_path, check_writable_dir, write_text
from trossen_arm_mujoco.real.validate import ARMS, DRIVER_LABELS, DRIVER_UNITS

__all__ = [
    "LABELS",
    "PLOT_HINT",
    "UNITS",
    "TrackingLog",
    "check_outputs",
    "format_error_table",
    "output_paths",
    "plot_tracking",
    "write_outputs",
]

#: Column labels of the 14 logged values: ``left_joint_0`` ... ``right_gripper``.
LABELS: tuple[str, ...] = tuple(f"{arm}_{name}" for arm in ARMS for name in DRIVER_LABELS)
UNITS: tuple[str, ...] = DRIVER_UNITS * 2

PLOT_HINT = "pip install 'trossen-arm-mujoco[video]' (matplotlib)"


@dataclass
class TrackingLog:
    """Commanded and measured positions, one entry per streamed step."""

    times: list[float] = field(default_factory=list)
    commanded: list[np.ndarray] = field(default_factory=list)
    measured: list[np.ndarray] = field(default_factory=list)

    def add(self, time_s: float, commanded: np.ndarray, measured: np.ndarray) -> None:
        """Record one step.

        Args:
            time_s: seconds since streaming began, at the moment of measurement.
            commanded: ``(2, 7)`` (left, right) positions as sent (rad; gripper m).
            measured: ``(2, 7)`` positions read back.
        """
        self.times.append(float(time_s))
        self.commanded.append(np.asarray(commanded, dtype=np.float64).reshape(14))
        self.measured.append(np.asarray(measured, dtype=np.float64).reshape(14))

    def __len__(self) -> int:
        return len(self.times)

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(times (N,), commanded (N, 14), measured (N, 14))``, float64."""
        n = len(self)
        return (
            np.asarray(self.times, dtype=np.float64).reshape(n),
            np.asarray(self.commanded, dtype=np.float64).reshape(n, 14),
            np.asarray(self.measured, dtype=np.float64).reshape(n, 14),
        )

    def errors(self) -> dict[str, dict[str, Any]]:
        """Per joint label: ``{"rms", "max", "unit"}`` of measured - commanded (None if empty)."""
        _, cmd, meas = self.arrays()
        err = meas - cmd
        out: dict[str, dict[str, Any]] = {}
        for j, (label, unit) in enumerate(zip(LABELS, UNITS, strict=True)):
            e = err[:, j]
            rms = float(np.sqrt(np.mean(e**2))) if e.size else None
            peak = float(np.max(np.abs(e))) if e.size else None
            out[label] = {"rms": rms, "max": peak, "unit": unit}
        return out


def format_error_table(errors: dict[str, dict[str, Any]]) -> str:
    """Tracking errors as a text table: joints as rows, left and right arms side by side.

    Gripper rows are in mm, joint rows in mrad; ``errors`` must come from a non-empty log.
    """
    lines = [f"{'joint':<9}{'left rms':>10}{'left max':>10}{'right rms':>11}{'right max':>11}"]
    for name, unit in zip(DRIVER_LABELS, DRIVER_UNITS, strict=True):
        shown = "mm" if unit == "m" else "mrad"
        cells = []
        for arm in ARMS:
            e = errors[f"{arm}_{name}"]
            cells += [e["rms"] * 1000.0, e["max"] * 1000.0]
        lines.append(
            f"{name + ' ' + shown:<9}{cells[0]:>10.2f}{cells[1]:>10.2f}"
            f"{cells[2]:>11.2f}{cells[3]:>11.2f}"
        )
    return "\n".join(lines)


def _csv_text(log: TrackingLog) -> str:
    times, cmd, meas = log.arrays()
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    header = ["step", "time_s"]
    for label in LABELS:
        header += [f"cmd_{label}", f"meas_{label}"]
    writer.writerow(header)
    for i in range(len(log)):
        row: list[str] = [str(i), f"{times[i]:.4f}"]
        for j in range(14):
            row += [f"{cmd[i, j]:.6f}", f"{meas[i, j]:.6f}"]
        writer.writerow(row)
    return buf.getvalue()


def plot_tracking(log: TrackingLog, path: Path, title: str) -> None:
    """Save commanded vs measured positions, 7 rows x 2 arms, as a PNG at ``path``.

    Uses matplotlib's Agg canvas directly (no pyplot, no global backend change).

    Args:
        log: the replay's tracking log.
        path: the PNG to write.
        title: the figure's title.

    Raises:
        ImportError: matplotlib is not installed.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    times, cmd, meas = log.arrays()
    fig = Figure(figsize=(12, 14), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(7, 2, sharex=True, squeeze=False)
    for a, arm in enumerate(ARMS):
        for j, (name, unit) in enumerate(zip(DRIVER_LABELS, DRIVER_UNITS, strict=True)):
            ax = axes[j, a]
            k = a * 7 + j
            ax.plot(times, cmd[:, k], label="commanded", linewidth=1.2)
            ax.plot(times, meas[:, k], label="measured", linewidth=1.0, linestyle="--")
            ax.set_ylabel(f"{name} ({unit})", fontsize=8)
            ax.tick_params(labelsize=7)
            if j == 0:
                ax.set_title(f"{arm} arm", fontsize=10)
        axes[-1, a].set_xlabel("time (s)")
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle(title, fontsize=11)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=80)


def output_paths(out_dir: Path, stem: str) -> dict[str, Path]:
    """Where :func:`write_outputs` writes: ``{"csv", "summary", "plot"}`` in ``out_dir``."""
    return {
        "csv": out_dir / f"{stem}_tracking.csv",
        "summary": out_dir / f"{stem}_summary.json",
        "plot": out_dir / f"{stem}_tracking.png",
    }


def check_outputs(out_dir: Path, stem: str, flag: str) -> Path:
    """Check, before any arm moves, that :func:`write_outputs` can write its files.

    The folder is checked for real (:func:`~trossen_arm_mujoco.fileio.check_writable_dir`:
    a part of the path that is a file, a read-only or full file system, missing
    permissions), then created; a folder in the place of one of the files is refused too
    (the files themselves are replaced by a rename, which needs only the folder).

    Args:
        out_dir: the output folder.
        stem: the files' common prefix (``episode_<k>_<backend>``).
        flag: the command-line flag that chooses the folder, named in the error.

    Returns:
        ``out_dir``, created.

    Raises:
        UserError: one line naming ``flag`` and what to do.
    """
    out_dir = check_writable_dir(out_dir, flag)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:  # the folder changed since the check
        raise UserError(
            f"cannot write to {flag} {out_dir}: {describe_os_error(exc)}; "
            f"{os_error_hint(exc, flag)}"
        ) from None
    for path in output_paths(out_dir, stem).values():
        if path.is_dir() and not path.is_symlink():  # a rename cannot replace a folder
            raise UserError(
                f"cannot write to {flag} {out_dir}: {path.name} there is a folder, where "
                f"the replay writes a file; move it away or choose another {flag}"
            )
    return out_dir


def write_outputs(
    out_dir: Path, stem: str, log: TrackingLog, summary: dict[str, Any]
) -> dict[str, Path | None]:
    """Write the CSV, the JSON summary (``summary`` + per-joint errors) and the plot.

    Args:
        out_dir: the folder (``<data folder>/replay/`` by default).
        stem: the files' name stem, ``episode_<k>_<backend>``.
        log: the replay's tracking log.
        summary: run metadata for the JSON file.

    Returns:
        ``{"csv", "summary", "plot"}`` paths; ``"plot"`` is None when matplotlib is
        missing (a note is added to the summary instead).
    """
    out_dir.mkdir(parents=True, exist_ok=True)
    paths: dict[str, Path | None] = dict(output_paths(out_dir, stem))
    csv_text = _csv_text(log)
    write_text(paths["csv"], csv_text)
    data = dict(summary)
    data["tracking_error"] = log.errors()
    if len(log):
        try:
            plot_tracking(log, paths["plot"], title=f"{stem}: commanded vs measured")
        except ImportError:
            paths["plot"] = None
            data["plot"] = f"not written: matplotlib is not installed ({PLOT_HINT})"
    else:
        paths["plot"] = None
        data["plot"] = "not written: no step was streamed"
    text = json.dumps(data, indent=2)
    write_text(paths["summary"], text + "\n")
    return paths
