"""Replay of recorded episodes on real Trossen AI arms, or on their MuJoCo twin.

The parts: :mod:`.driver` (the :class:`ArmDriver` protocol, the ``trossen_arm`` backend),
:mod:`.sim_driver` (the simulated twin of one arm), :mod:`.clock` (wall-clock and simulated
time), :mod:`.validate` (trajectory checks), :mod:`.preflight` (addresses and step period,
checked before anything connects), :mod:`.gripper` (gripper commands clamped and counted),
:mod:`.replay` (the rate-limited loop), :mod:`.shutdown` (one-line driver errors, the safe
exit), :mod:`.report` (tracking CSV, JSON, plot).
The command line is ``scripts/replay_episode_real.py`` (``trossen-mujoco replay-real``).

Docs: docs/cli/replay-real.md.
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
