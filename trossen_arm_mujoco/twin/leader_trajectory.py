"""What a pair of served leader arms plays: an episode's joint values per arm, sampled in
time (``twin.leaders`` serves them).

:func:`load_leader_trajectory` reads an episode file (this package's or a vendor recording)
in the real kit's layout, 7 values per arm (rad x6, gripper m), clipped to the driver's joint
ranges; :meth:`LeaderTrajectory.sample` gives position and velocity at any time.

Docs: docs/cli/serve.md, docs/cli/teleop.md.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.data.reader import load_episode
from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.real.validate import ArmLimits
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, SIDES

__all__ = ["SOURCES", "LeaderTrajectory", "load_leader_trajectory"]

#: What a replay can play: the episode's actions or its measured joint positions.
SOURCES: tuple[str, ...] = ("action", "qpos")


@dataclass(frozen=True)
class LeaderTrajectory:
    """The joint positions two leader arms play.

    Attributes:
        positions: float64 ``(T, 2, 7)``: per step, ``[left, right]`` arm values (rad x6,
            gripper m), within the arm's joint ranges.
        dt: step period of the episode (s).
        path: the episode file.
        source: ``"action"`` or ``"qpos"``.
    """

    positions: np.ndarray
    dt: float
    path: Path
    source: str = "action"

    @property
    def num_steps(self) -> int:
        """Number of steps (rows of ``positions``)."""
        return int(self.positions.shape[0])

    @property
    def duration(self) -> float:
        """Seconds from the first to the last step at speed 1."""
        return (self.num_steps - 1) * self.dt

    def sample(self, arm: int, seconds: float) -> tuple[np.ndarray, np.ndarray]:
        """Position (rad x6, m) and velocity (rad/s x6, m/s) of arm ``arm`` (0 left, 1 right)
        ``seconds`` into the episode (linear between steps; held before 0 and after the
        end, with zero velocity)."""
        p = self.positions[:, arm]
        if self.num_steps == 1 or seconds <= 0.0:
            return p[0].copy(), np.zeros(7)
        if seconds >= self.duration:
            return p[-1].copy(), np.zeros(7)
        x = seconds / self.dt
        i = min(int(x), self.num_steps - 2)
        frac = x - i
        slope = p[i + 1] - p[i]
        return p[i] + frac * slope, slope / self.dt


def load_leader_trajectory(
    path: str | os.PathLike[str], source: str = "action"
) -> LeaderTrajectory:
    """Read an episode file (this package's or a vendor recording) as a leader trajectory.

    Raises:
        UserError: unknown ``source``; the file is missing or invalid (one line).
    """
    if source not in SOURCES:
        raise unknown_name_error("replay source", source, SOURCES)
    episode = load_episode(path)
    values = KIT14_LAYOUT.from_vendor(episode.action if source == "action" else episode.qpos)
    limits = ArmLimits.from_mjcf()
    arms = np.stack(
        [values[:, KIT14_LAYOUT.arm(s).start : KIT14_LAYOUT.arm(s).start + 7] for s in SIDES],
        axis=1,
    )
    arms = np.clip(arms, limits.driver_lower, limits.driver_upper)
    return LeaderTrajectory(arms, float(episode.dt), Path(path), source)
