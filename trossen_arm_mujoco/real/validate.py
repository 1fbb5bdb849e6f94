"""Check a whole trajectory against the arm's limits before anything moves.

:func:`validate_actions` checks a ``(T, 16)`` action array (layout of
``constants.START_ARM_POSE``), in this order: shape with ``T >= 1``; every value finite;
every value within the single-arm MJCF's joint range (values at most
:data:`POSITION_TOLERANCE` outside are clipped: MuJoCo's soft limits let simulated
recordings press a few mrad past them); the speed between consecutive commands at the replay
rate, ``|a[t+1] - a[t]| * fps``, of the 7 values sent to each arm, within
:data:`VELOCITY_LIMITS` (the URDF's) plus :data:`VELOCITY_TOLERANCE`. The first violation
raises :class:`TrajectoryError` (a ``UserError``: one line, exit 2) naming the step, arm,
joint, value and limit.

Docs: docs/cli/replay-real.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.real.sim_driver import ARM_XML
from trossen_arm_mujoco.robot.configs import JOINT_VELOCITY_LIMITS
from trossen_arm_mujoco.robot.layout import ARM_VALUES, VENDOR16_LAYOUT

__all__ = [
    "ARMS",
    "DATASET_JOINTS",
    "DRIVER_LABELS",
    "DRIVER_UNITS",
    "POSITION_TOLERANCE",
    "VELOCITY_LIMITS",
    "VELOCITY_TOLERANCE",
    "ArmLimits",
    "Trajectory",
    "TrajectoryError",
    "format_trajectory_report",
    "safe_move_time",
    "validate_actions",
]

ARMS: tuple[str, str] = ("left", "right")

#: MJCF joints of one arm in dataset order (8 values per arm).
DATASET_JOINTS: tuple[str, ...] = ARM_VALUES

#: Labels of the 7 values sent to a driver.
DRIVER_LABELS: tuple[str, ...] = (*(f"joint_{i}" for i in range(6)), "gripper")

#: Units of the 7 driver values.
DRIVER_UNITS: tuple[str, ...] = ("rad",) * 6 + ("m",)

#: Velocity limits of the 7 driver values (URDF: rad/s x6, gripper carriage m/s), from the
#: robot layer's table.
VELOCITY_LIMITS: tuple[float, ...] = tuple(JOINT_VELOCITY_LIMITS[j] for j in DATASET_JOINTS[:7])

#: Allowed excess over VELOCITY_LIMITS, as a fraction: the check is conservative (it
#: takes each step as a jump at the command rate, while the controller spreads each
#: command over goal_time > 1/fps); 2% lets vendor recordings replay at the default
#: 10 fps, whose gripper opens at 0.0880 m/s in the first steps.
VELOCITY_TOLERANCE: float = 0.02

#: How far outside a joint range a value may be and still be clipped to it (rad, m).
POSITION_TOLERANCE: dict[str, float] = {"rad": 0.01, "m": 0.001}


class TrajectoryError(UserError):
    """The trajectory is malformed or outside the arm's limits; nothing was moved."""


@dataclass(frozen=True)
class ArmLimits:
    """Position limits of one arm (both arms are identical).

    Attributes:
        lower, upper: float64 ``(8,)`` joint ranges in dataset order (rad x6, m x2).
        velocity: float64 ``(7,)`` speed limits of the driver values (rad/s x6, m/s).
    """

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray

    @classmethod
    def from_mjcf(cls, xml_path: str | Path = ARM_XML) -> ArmLimits:
        """Read the joint ranges from the single-arm MJCF."""
        model = mujoco.MjModel.from_xml_path(str(xml_path))
        ranges = np.array([model.jnt_range[lookup_id(model, "joint", j)] for j in DATASET_JOINTS])
        return cls(ranges[:, 0].copy(), ranges[:, 1].copy(), np.array(VELOCITY_LIMITS))

    @property
    def driver_lower(self) -> np.ndarray:
        """Lower limits of the 7 driver values."""
        return self.lower[:7]

    @property
    def driver_upper(self) -> np.ndarray:
        """Upper limits of the 7 driver values."""
        return self.upper[:7]


@dataclass
class Trajectory:
    """A validated trajectory, split per arm.

    Attributes:
        commands: float64 ``(T, 2, 7)``: per step, ``[left, right]`` driver commands
            (rad x6, gripper m) after clipping.
        fps: replay rate it was validated for (Hz).
        clipped: number of dataset values clipped to a joint range.
        max_clip: largest clip applied (rad or m; 0 when none).
        peak_speed: float64 ``(2, 7)`` largest speed between steps (rad/s, m/s).
        max_fps: highest replay rate within the speed limits (inf for one step).
    """

    commands: np.ndarray
    fps: float
    clipped: int
    max_clip: float
    peak_speed: np.ndarray
    max_fps: float

    @property
    def num_steps(self) -> int:
        """Number of steps T."""
        return int(self.commands.shape[0])


def _where(step: int, column: int) -> str:
    arm, joint = ARMS[column // 8], DATASET_JOINTS[column % 8]
    return f"step {step}, {arm} arm, {joint}"


def validate_actions(
    actions: np.ndarray, fps: float, limits: ArmLimits | None = None
) -> Trajectory:
    """Validate an action array for replay; see the module doc.

    Args:
        actions: ``(T, 16)`` actions (layout of ``constants.START_ARM_POSE``; rad, m).
        fps: the replay rate (Hz).
        limits: the arm's limits; None: the defaults (MJCF ranges, URDF speeds).

    Returns:
        The checked :class:`Trajectory` (values within tolerance clipped to the range).

    Raises:
        TrajectoryError: the first violation, in one line.
    """
    limits = limits if limits is not None else ArmLimits.from_mjcf()
    actions = np.asarray(actions)
    if actions.ndim != 2 or actions.shape[1] != 16 or actions.shape[0] < 1:
        raise TrajectoryError(
            f"actions have shape {actions.shape}, expected (T, 16) with T >= 1 "
            "(left j0..j5, 2 fingers, right j0..j5, 2 fingers)"
        )
    actions = actions.astype(np.float64)
    bad = ~np.isfinite(actions)
    if bad.any():
        step, col = (int(i) for i in np.argwhere(bad)[0])
        raise TrajectoryError(f"{_where(step, col)}: value is {actions[step, col]} (not finite)")

    lower, upper = np.tile(limits.lower, 2), np.tile(limits.upper, 2)
    units = np.tile(np.array(["rad"] * 6 + ["m"] * 2), 2)
    tol = np.array([POSITION_TOLERANCE[u] for u in units])
    excess = np.maximum(lower - actions, actions - upper)
    beyond = excess > tol
    if beyond.any():
        step, col = (int(i) for i in np.argwhere(beyond)[0])
        unit = units[col]
        raise TrajectoryError(
            f"{_where(step, col)}: {actions[step, col]:.5g} {unit} is outside the joint "
            f"limits [{lower[col]:.5g}, {upper[col]:.5g}] {unit} (tolerance {tol[col]:g} {unit})"
        )
    clipped_mask = excess > 0
    clipped = np.clip(actions, lower, upper)

    # (T, 2, 7): per arm the 7 driver values
    commands = np.stack([clipped[:, VENDOR16_LAYOUT.driver_slice(a)] for a in ARMS], axis=1)
    if commands.shape[0] > 1:
        steps = np.abs(np.diff(commands, axis=0))  # (T-1, 2, 7), per command period
        peak = steps.max(axis=0) * fps
        allowed = limits.velocity * (1.0 + VELOCITY_TOLERANCE)
        with np.errstate(divide="ignore"):
            max_fps = float(np.min(allowed / steps.max(axis=0)))
        fast = steps * fps > allowed
        if fast.any():
            step, arm, joint = (int(i) for i in np.argwhere(fast)[0])
            unit = DRIVER_UNITS[joint]
            speed = steps[step, arm, joint] * fps
            raise TrajectoryError(
                f"step {step} -> {step + 1}, {ARMS[arm]} arm, {DRIVER_LABELS[joint]}: speed "
                f"{speed:.4g} {unit}/s exceeds the limit {limits.velocity[joint]:g} {unit}/s "
                f"(+{VELOCITY_TOLERANCE:.0%}) at --fps {fps:g}; this trajectory needs "
                f"--fps {np.floor(max_fps * 10) / 10:g} or lower"
            )
    else:
        peak, max_fps = np.zeros((2, 7)), float("inf")
    return Trajectory(
        commands=commands,
        fps=float(fps),
        clipped=int(clipped_mask.sum()),
        max_clip=float(excess[clipped_mask].max()) if clipped_mask.any() else 0.0,
        peak_speed=peak,
        max_fps=max_fps,
    )


def safe_move_time(start: np.ndarray, goal: np.ndarray, minimum: float, limits: ArmLimits) -> float:
    """Goal time (s) for a point-to-point move within the speed limits.

    Assumes a quintic profile (peak speed 1.875 x mean speed) and keeps a 10% margin.

    Args:
        start: ``(..., 7)`` driver values (rad; gripper m).
        goal: ``(..., 7)`` driver values.
        minimum: the shortest goal time (s).
        limits: the arm's limits (speeds).
    """
    dist = np.abs(np.asarray(goal, dtype=np.float64) - np.asarray(start, dtype=np.float64))
    need = float(np.max(1.875 * 1.1 * dist / limits.velocity)) if dist.size else 0.0
    return max(float(minimum), need)


def format_trajectory_report(trajectory: Trajectory, limits: ArmLimits) -> str:
    """What would be sent, per arm and joint: range, peak speed and its share of the limit."""
    cmd = trajectory.commands
    lines = [
        f"{'arm':<6}{'joint':<9}{'min':>10}{'max':>10}{'peak speed':>12}{'limit':>9}{'use':>6}"
    ]
    for a, arm in enumerate(ARMS):
        for j, (name, unit) in enumerate(zip(DRIVER_LABELS, DRIVER_UNITS, strict=True)):
            peak, lim = trajectory.peak_speed[a, j], limits.velocity[j]
            lines.append(
                f"{arm:<6}{name:<9}{cmd[:, a, j].min():>10.4f}{cmd[:, a, j].max():>10.4f}"
                f"{peak:>12.4f}{lim:>9.4g}{peak / lim:>6.0%}  ({unit}, {unit}/s)"
            )
    lines.append(
        f"clipped to joint limits: {trajectory.clipped} value(s), largest by "
        f"{trajectory.max_clip:.3g}; highest valid --fps: {trajectory.max_fps:.3g}"
    )
    return "\n".join(lines)
