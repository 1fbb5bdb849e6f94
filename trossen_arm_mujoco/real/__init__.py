"""Replay of recorded episodes on real Trossen AI arms, or on their MuJoCo twin.

- :mod:`.driver`: the :class:`ArmDriver` protocol and the real ``trossen_arm`` backend;
- :mod:`.sim_driver`: :class:`SimArmDriver`, the simulated twin of one arm;
- :mod:`.clock`: wall-clock and simulated time;
- :mod:`.validate`: trajectory checks against joint and speed limits;
- :mod:`.preflight`: the arms' addresses and the episode's step period, checked before
  anything connects;
- :mod:`.gripper`: gripper commands clamped to the controller's range, and counted;
- :mod:`.replay`: the rate-limited replay loop;
- :mod:`.shutdown`: driver calls as one-line errors, and the safe home/sleep/cleanup exit;
- :mod:`.stop`: SIGINT, SIGTERM, SIGHUP and SIGQUIT as a stop flag;
- :mod:`.report`: tracking-error CSV, JSON summary and plot.

The command line is ``scripts/replay_episode_real.py`` (``trossen-mujoco replay-real``).
"""

from trossen_arm_mujoco.real.clock import Clock, SimClock, WallClock
from trossen_arm_mujoco.real.driver import (
    HOME_POSE,
    SLEEP_POSE,
    ArmDriver,
    TrossenArmDriver,
    end_effector_presets,
    split_arms,
)
from trossen_arm_mujoco.real.gripper import GRIPPER_MAX, GripperClamp, clamp_gripper
from trossen_arm_mujoco.real.replay import ReplayConfig, ReplayResult, make_drivers, replay
from trossen_arm_mujoco.real.shutdown import DriverError
from trossen_arm_mujoco.real.sim_driver import SimArmDriver
from trossen_arm_mujoco.real.validate import (
    ArmLimits,
    Trajectory,
    TrajectoryError,
    validate_actions,
)

__all__ = [
    "GRIPPER_MAX",
    "HOME_POSE",
    "SLEEP_POSE",
    "ArmDriver",
    "ArmLimits",
    "Clock",
    "DriverError",
    "GripperClamp",
    "ReplayConfig",
    "ReplayResult",
    "SimArmDriver",
    "SimClock",
    "Trajectory",
    "TrajectoryError",
    "TrossenArmDriver",
    "WallClock",
    "clamp_gripper",
    "end_effector_presets",
    "make_drivers",
    "replay",
    "split_arms",
    "validate_actions",
]
