"""MujocoEnv: the world of one episode (model, data, robots, cameras, objects) and stepping.

Timing: ``sim_dt`` is the model timestep; every ``ctrl_dt`` the robots compute their control,
then physics runs ``ctrl_dt / sim_dt`` steps. The ratio must be a whole number.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import mujoco
import numpy as np
from dm_control import mujoco as dm_mujoco

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import RobotConfig
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.sim.cameras import CameraSet
from trossen_arm_mujoco.sim.objects import FreeJointObject


def whole_ratio(longer: float, shorter: float, longer_name: str, shorter_name: str) -> int:
    """``longer / shorter`` as an int; a UserError saying so when it is not whole."""
    if shorter <= 0 or longer <= 0:
        raise UserError(f"{longer_name} and {shorter_name} must be positive")
    ratio = longer / shorter
    n = int(round(ratio))
    if n < 1 or abs(ratio - n) > 1e-6:
        raise UserError(
            f"{longer_name} ({longer:g} s) must be a whole multiple of {shorter_name} "
            f"({shorter:g} s); the ratio is {ratio:.4f}"
        )
    return n


def load_physics(xml_path: str | Path) -> dm_mujoco.Physics:
    """dm_control Physics from an MJCF file, with one-line errors for missing/broken files."""
    path = Path(xml_path)
    if not path.is_file():
        raise UserError(f"model file not found: {path}")
    try:
        return dm_mujoco.Physics.from_xml_path(str(path))
    except Exception as exc:  # dm_control wraps mujoco's ValueError in several types
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UserError(f"cannot load model {path}: {first}") from exc


class MujocoEnv:
    """Owns a dm_control ``Physics`` and the robots, objects and cameras living in it.

    Args:
        xml_path: MJCF scene to load (or pass ``physics``).
        robots: robot name -> config; each becomes a ``Robot`` over the model, controlled
            every ``ctrl_dt`` (its velocity limits are enforced per control tick).
        objects: object name -> (free joint name, geom name or None).
        camera_names, height, width: cameras rendered by ``render_images``.
        ctrl_dt: control period (s); default: one physics step.
        keyframe: keyframe loaded at reset when the model has it.
    """

    def __init__(
        self,
        xml_path: str | Path | None = None,
        *,
        physics: dm_mujoco.Physics | None = None,
        robots: Mapping[str, RobotConfig] | None = None,
        objects: Mapping[str, tuple[str, str | None]] | None = None,
        camera_names: Sequence[str] = (),
        height: int = 480,
        width: int = 640,
        ctrl_dt: float | None = None,
        keyframe: str = "home",
    ):
        if physics is None:
            if xml_path is None:
                raise UserError("MujocoEnv needs an xml_path or a physics")
            physics = load_physics(xml_path)
        self.physics = physics
        self.model: mujoco.MjModel = physics.model.ptr
        self.data: mujoco.MjData = physics.data.ptr
        self.sim_dt = float(self.model.opt.timestep)
        self.ctrl_dt = float(ctrl_dt) if ctrl_dt is not None else self.sim_dt
        self.n_substeps = whole_ratio(self.ctrl_dt, self.sim_dt, "ctrl_dt", "sim_dt")
        self.robots = {
            n: Robot(self.model, c, ctrl_dt=self.ctrl_dt) for n, c in (robots or {}).items()
        }
        self.objects = {
            n: FreeJointObject(self.model, j, g) for n, (j, g) in (objects or {}).items()
        }
        self.cameras = CameraSet(self.model, camera_names, height, width)
        self.keyframe_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, keyframe)

    def reset(self) -> None:
        """Keyframe (or model defaults), robots at their initial joints, controls at no-op."""
        if self.keyframe_id >= 0:
            mujoco.mj_resetDataKeyframe(self.model, self.data, self.keyframe_id)
        else:
            mujoco.mj_resetData(self.model, self.data)
        for robot in self.robots.values():
            robot.reset(self.data)
        mujoco.mj_forward(self.model, self.data)

    def forward(self) -> None:
        mujoco.mj_forward(self.model, self.data)

    def apply_control(self) -> None:
        """Let every robot compute and write its control (no physics step)."""
        for robot in self.robots.values():
            robot.compute_control(self.data)

    def step(self, n_ctrl_steps: int = 1) -> None:
        """Advance ``n_ctrl_steps`` control periods: control, then ``n_substeps`` physics steps."""
        for _ in range(n_ctrl_steps):
            self.apply_control()
            self.physics.step(self.n_substeps)

    def render_images(self) -> dict[str, np.ndarray]:
        """Images of the configured cameras, uint8 (H, W, 3) by name."""
        return self.cameras.render_all(self.data)

    def warnings(self) -> list[str]:
        """Names of MuJoCo warnings raised so far (e.g. 'mjWARN_BADQACC')."""
        return [
            mujoco.mjtWarning(i).name
            for i in range(len(self.data.warning))
            if self.data.warning[i].number > 0
        ]

    def close(self) -> None:
        self.cameras.close()
