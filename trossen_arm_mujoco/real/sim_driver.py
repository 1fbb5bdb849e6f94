"""The simulated twin of one arm: :class:`SimArmDriver`, an :class:`ArmDriver` over MuJoCo.

It runs the single-arm model ``assets/wxai/wxai_follower.xml`` (timestep 0.002 s). Like the
real controller, each ``set_all_positions`` starts a setpoint trajectory from the current
setpoint to the goal over ``goal_time`` (:mod:`.goal_trajectory`), updated every physics
step (500 Hz); the position actuators track it, so the measured arm lags by real dynamics.
Nothing moves between calls: :meth:`SimArmDriver.advance` simulates a span of time, called by
the shared :class:`~trossen_arm_mujoco.real.clock.SimClock` on every ``clock.sleep(dt)``, so
replay runs at simulation speed with the same code that waits in real time on real arms.

Docs: docs/cli/replay-real.md (``--backend sim``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from trossen_arm_mujoco.assets import ASSETS_DIR
from trossen_arm_mujoco.errors import unknown_name_error
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.real.clock import SimClock
from trossen_arm_mujoco.real.driver import (
    DEFAULT_END_EFFECTOR,
    DEFAULT_MODEL,
    NUM_ARM_VALUES,
    SLEEP_POSE,
)
from trossen_arm_mujoco.real.goal_trajectory import QUINTIC_MIN_GOAL_TIME, GoalTrajectory

__all__ = [
    "ACTUATORS",
    "ARM_XML",
    "JOINTS",
    "QUINTIC_MIN_GOAL_TIME",
    "SIM_END_EFFECTORS",
    "SIM_MODELS",
    "SimArmDriver",
]

#: Single-arm model of the twin.
ARM_XML: Path = Path(ASSETS_DIR) / "wxai" / "wxai_follower.xml"

#: Joints read by get_all_positions (the gripper is the actuated carriage) and actuators.
JOINTS: tuple[str, ...] = (*(f"joint_{i}" for i in range(6)), "left_carriage_joint")
ACTUATORS: tuple[str, ...] = (*(f"joint_{i}" for i in range(6)), "gripper")

#: Model and end-effector presets the twin accepts (it simulates the follower arm).
SIM_MODELS: tuple[str, ...] = ("wxai_v0",)
SIM_END_EFFECTORS: tuple[str, ...] = ("wxai_v0_follower", "wxai_v0_leader", "wxai_v0_base")


class SimArmDriver:
    """:class:`~trossen_arm_mujoco.real.driver.ArmDriver` backed by the MuJoCo twin.

    Args:
        clock: simulated time shared with the other arm; a private one when None. The
            driver attaches itself, so ``clock.sleep(dt)`` advances its physics.
        initial_positions: 7 starting values (rad x6, gripper m); the sleep pose
            (all zeros) when None, where a powered-down arm rests.
        xml_path: the single-arm MJCF.
    """

    def __init__(
        self,
        clock: SimClock | None = None,
        initial_positions: Sequence[float] | None = None,
        xml_path: str | Path = ARM_XML,
    ) -> None:
        self.clock = clock if clock is not None else SimClock()
        self.model = mujoco.MjModel.from_xml_path(str(xml_path))
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._qadr = np.array([m.jnt_qposadr[lookup_id(m, "joint", j)] for j in JOINTS])
        twin = lookup_id(m, "joint", "right_carriage_joint")
        self._twin_qadr = int(m.jnt_qposadr[twin])
        self._act = np.array([lookup_id(m, "actuator", a) for a in ACTUATORS])
        self._ctrl_lo = m.actuator_ctrlrange[self._act, 0].copy()
        self._ctrl_hi = m.actuator_ctrlrange[self._act, 1].copy()
        start = np.asarray(
            SLEEP_POSE if initial_positions is None else initial_positions, dtype=np.float64
        )
        if start.shape != (NUM_ARM_VALUES,):
            raise ValueError(f"initial_positions must have 7 values, got shape {start.shape}")
        self.data.qpos[self._qadr] = start
        self.data.qpos[self._twin_qadr] = start[-1]
        self.data.ctrl[self._act] = np.clip(start, self._ctrl_lo, self._ctrl_hi)
        mujoco.mj_forward(m, self.data)
        self._segment: GoalTrajectory | None = None
        self._seg_time = 0.0
        self._pending = 0.0
        self.configured = False
        self.position_mode = False
        self.ip_address: str | None = None
        self.clock.attach(self)

    @property
    def timestep(self) -> float:
        """Physics (and control) period (s)."""
        return float(self.model.opt.timestep)

    @property
    def sim_time(self) -> float:
        """Simulated time of this arm (s)."""
        return float(self.data.time)

    def configure(
        self,
        ip_address: str,
        model: str = DEFAULT_MODEL,
        end_effector: str = DEFAULT_END_EFFECTOR,
        clear_error: bool = True,
    ) -> None:
        """Accept the same arguments as the real driver.

        Args:
            ip_address: the arm controller's address (only recorded).
            model: robot model name, e.g. ``"wxai_v0"``.
            end_effector: end-effector preset name, e.g. ``"wxai_v0_follower"``.
            clear_error: clear a latched error state of the controller.
        """
        if model not in SIM_MODELS:
            raise unknown_name_error("robot model", model, SIM_MODELS, "simulated twin")
        if end_effector not in SIM_END_EFFECTORS:
            raise unknown_name_error("end effector", end_effector, SIM_END_EFFECTORS)
        self.ip_address = ip_address
        self.configured = True
        self._segment = None

    def set_all_modes_position(self) -> None:
        """Enable position control (commands are refused before this)."""
        self._require_configured()
        self.position_mode = True

    def _require_configured(self) -> None:
        if not self.configured:
            raise RuntimeError("arm driver is not configured; call configure() first")

    def setpoint(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Current setpoint: position, velocity, acceleration, float64 ``(7,)`` each."""
        if self._segment is None:
            pos = self.data.ctrl[self._act].copy()
            return pos, np.zeros(NUM_ARM_VALUES), np.zeros(NUM_ARM_VALUES)
        return self._segment.sample(self._seg_time)

    def set_all_positions(
        self, positions: Sequence[float], goal_time: float, blocking: bool
    ) -> None:
        """Start moving toward ``positions`` (7 values: rad x6, gripper m) over ``goal_time`` s.

        Goals outside the actuator ranges are clamped to them.

        Args:
            positions: 7 values: ``joint_0`` .. ``joint_5`` (rad), gripper (m).
            goal_time: seconds until the goal is reached (simulated time).
            blocking: sleep the shared clock for ``goal_time`` (both arms move meanwhile).
        """
        self._require_configured()
        if not self.position_mode:
            raise RuntimeError("position mode is not set; call set_all_modes_position() first")
        goal = np.asarray(positions, dtype=np.float64)
        if goal.shape != (NUM_ARM_VALUES,):
            raise ValueError(f"expected {NUM_ARM_VALUES} positions, got shape {goal.shape}")
        if not np.all(np.isfinite(goal)):
            raise ValueError(f"positions must be finite, got {goal.tolist()}")
        goal = np.clip(goal, self._ctrl_lo, self._ctrl_hi)
        duration = float(goal_time) if goal_time >= self.timestep else 0.0
        p0, v0, a0 = self.setpoint()
        self._segment = GoalTrajectory(p0, v0, a0, goal, duration)
        self._seg_time = 0.0
        if blocking:
            self.clock.sleep(float(goal_time))

    def get_all_positions(self) -> np.ndarray:
        """Measured positions, float64 ``(7,)``: joints (rad), actuated carriage (m)."""
        return self.data.qpos[self._qadr].copy()

    def advance(self, seconds: float) -> None:
        """Simulate ``seconds`` (s): whole physics steps, carrying the remainder over."""
        self._pending += seconds
        steps = int(np.floor(self._pending / self.timestep + 1e-9))
        self._pending -= steps * self.timestep
        model, data, dt = self.model, self.data, self.timestep
        for _ in range(steps):
            if self._segment is not None:
                pos, _, _ = self._segment.sample(self._seg_time)
                data.ctrl[self._act] = pos
                self._seg_time += dt
            mujoco.mj_step(model, data)

    def cleanup(self) -> None:
        """Disconnect: further commands are refused; the arm holds its last setpoint."""
        self.configured = False
        self.position_mode = False
