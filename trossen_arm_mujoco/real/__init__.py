"""Replay of recorded episodes on real Trossen AI arms, or on their MuJoCo twin.

- :mod:`.driver`: the :class:`ArmDriver` protocol and the real ``trossen_arm`` backend;
- :mod:`.sim_driver`: :class:`SimArmDriver`, the simulated twin of one arm;
- :mod:`.clock`: wall-clock and simulated time;
- :mod:`.validate`: trajectory checks against joint and speed limits;
- :mod:`.replay`: the rate-limited replay loop with a safe home/sleep exit;
- :mod:`.report`: tracking-error CSV, JSON summary and plot.

The command line is ``scripts/replay_episode_real.py`` (``trossen-mujoco replay-real``).
"""

from trossen_arm_mujoco.real.clock import Clock, SimClock, WallClock
from trossen_arm_mujoco.real.driver import (
    HOME_POSE,
    SLEEP_POSE,
    ArmDriver,
    TrossenArmDriver,
    split_arms,
)
from trossen_arm_mujoco.real.replay import ReplayConfig, ReplayResult, make_drivers, replay
from trossen_arm_mujoco.real.sim_driver import SimArmDriver
from trossen_arm_mujoco.real.validate import (
    ArmLimits,
    Trajectory,
    TrajectoryError,
    validate_actions,
)

__all__ = [
    "HOME_POSE",
    "SLEEP_POSE",
    "ArmDriver",
    "ArmLimits",
    "Clock",
    "ReplayConfig",
    "ReplayResult",
    "SimArmDriver",
    "SimClock",
    "Trajectory",
    "TrajectoryError",
    "TrossenArmDriver",
    "WallClock",
    "make_drivers",
    "replay",
    "split_arms",
    "validate_actions",
]
