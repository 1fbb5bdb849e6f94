"""Scene: the world of one episode (model, data, robots, cameras, objects) and stepping.

Timing: ``sim_dt`` is the model timestep; every ``ctrl_dt`` the robots compute their control,
then physics runs ``ctrl_dt / sim_dt`` steps. The ratio must be a whole number.
``Scene.step`` is the one stepping loop of the package: tasks and every gym stepping
regime advance time through it.

No GL: the scene works on a plain ``mujoco.MjModel``/``MjData`` and imports nothing that opens
a GL context (dm_control is imported only by ``load_physics``, for the dm_control front
doors); cameras create their renderer on the first image.

Docs: docs/reference/robot-sim.md.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

import mujoco

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.configs import RobotConfig
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.sim.cameras import CameraSet
from trossen_arm_mujoco.sim.looks import SceneLooks, checked_looks, compile_model
from trossen_arm_mujoco.sim.objects import FreeJointObject
from trossen_arm_mujoco.sim.scene_edit import SceneEdit

__all__ = ["Scene", "load_model", "load_physics", "whole_ratio"]

if TYPE_CHECKING:
    import numpy as np
    from dm_control.mujoco import Physics


def whole_ratio(longer: float, shorter: float, longer_name: str, shorter_name: str) -> int:
    """``longer / shorter`` as an int; a UserError saying so when it is not whole.

    Args:
        longer: the longer period (s).
        shorter: the shorter period (s).
        longer_name: the longer one's name, for the message (e.g. ``policy_dt``).
        shorter_name: the shorter one's name.
    """
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


def _one_line(exc: Exception) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _check_file(xml_path: str | Path) -> Path:
    path = Path(xml_path)
    if not path.is_file():
        raise UserError(f"model file not found: {path}")
    return path


def load_model(
    xml_path: str | Path, looks: SceneLooks | None = None, edit: SceneEdit | None = None
) -> mujoco.MjModel:
    """Compiled model from an MJCF file (no GL), with one-line errors for missing/broken
    files.

    Args:
        xml_path: the MJCF file.
        looks: shadows and arm meshes; None: ``SceneLooks()`` (own meshes, shadows on).
        edit: a task's own scene objects (``sim.scene_edit``); None: none.
    """
    path = _check_file(xml_path)
    looks = checked_looks(looks)
    try:
        return compile_model(path, looks, edit)
    except UserError:
        raise
    except Exception as exc:
        raise UserError(f"cannot load model {path}: {_one_line(exc)}") from exc


def load_physics(
    xml_path: str | Path, looks: SceneLooks | None = None, edit: SceneEdit | None = None
) -> Physics:
    """dm_control Physics from an MJCF file, with one-line errors for missing/broken files.

    Imports dm_control here (its import initializes the display of its GL backend), so only
    the dm_control front doors pay for it.

    Args:
        xml_path: the MJCF file.
        looks: shadows and arm meshes; None: ``SceneLooks()`` (own meshes, shadows on).
        edit: a task's own scene objects (``sim.scene_edit``); None: none.
    """
    path = _check_file(xml_path)
    looks = checked_looks(looks)
    from dm_control import mujoco as dm_mujoco

    try:
        if looks == SceneLooks() and not edit:
            return dm_mujoco.Physics.from_xml_path(str(path))
        model = dm_mujoco.wrapper.MjModel(compile_model(path, looks, edit))
        return dm_mujoco.Physics.from_model(model)
    except UserError:
        raise
    except Exception as exc:  # dm_control wraps mujoco's ValueError in several types
        raise UserError(f"cannot load model {path}: {_one_line(exc)}") from exc


class Scene:
    """Owns the model and data of a scene and the robots, objects and cameras living in it.

    Args:
        xml_path: MJCF scene to load (or pass ``model`` [and ``data``], or ``physics``).
        physics: a dm_control ``Physics`` to work on (the dm_control front doors); its
            ``step`` then advances physics, as dm_control does. Without it the scene uses a
            plain ``mujoco.MjModel``/``MjData`` and ``mujoco.mj_step``.
        model, data: a compiled model (and its data; default a new ``MjData``).
        robots: robot name -> config; each becomes a ``Robot`` over the model, controlled
            every ``ctrl_dt`` (its velocity limits are enforced per control tick).
        objects: object name -> (free joint name, geom name or None).
        camera_names, height, width: cameras rendered by ``render_images`` (the renderer is
            created on the first image).
        ctrl_dt: control period (s); default: one physics step.
        sim_dt: physics timestep (s) to use instead of the scene's ``<option timestep>``
            (e.g. a step that divides a control period of 1/30 s); default: the scene's.
        keyframe: keyframe loaded at reset when the model has it.
        looks: shadows and arm meshes of the scene loaded from ``xml_path`` (default
            ``SceneLooks()``; ``sim.looks``); a given ``physics`` or ``model`` keeps its own.
        table_height: height (m, world z) of the table top: every robot's arms are kept
            above ``table_height + floor_margin`` (``Robot.set_safety_floor``); None: no floor.
        floor_margin: the safety floor's height above the table top (m, >= 0).
        edit: a task's own objects composed into the scene loaded from ``xml_path``
            (``sim.scene_edit.SceneEdit``); default none.
    """

    def __init__(
        self,
        xml_path: str | Path | None = None,
        *,
        physics: Physics | None = None,
        model: mujoco.MjModel | None = None,
        data: mujoco.MjData | None = None,
        robots: Mapping[str, RobotConfig] | None = None,
        objects: Mapping[str, tuple[str, str | None]] | None = None,
        camera_names: Sequence[str] = (),
        height: int = 480,
        width: int = 640,
        ctrl_dt: float | None = None,
        sim_dt: float | None = None,
        keyframe: str = "home",
        looks: SceneLooks | None = None,
        table_height: float | None = None,
        floor_margin: float = 0.0,
        edit: SceneEdit | None = None,
    ):
        if physics is not None:
            model, data = physics.model.ptr, physics.data.ptr
        elif model is None:
            if xml_path is None:
                raise UserError("Scene needs an xml_path or a physics (or a compiled model)")
            model = load_model(xml_path, looks, edit)
        if data is None:
            data = mujoco.MjData(model)
        self.physics = physics
        self.model: mujoco.MjModel = model
        self.data: mujoco.MjData = data
        if sim_dt is not None:
            if not (0 < sim_dt <= 0.01):
                raise UserError(f"sim_dt must be in (0, 0.01] s, got {sim_dt!r}")
            self.model.opt.timestep = float(sim_dt)
        self.sim_dt = float(self.model.opt.timestep)
        self.ctrl_dt = float(ctrl_dt) if ctrl_dt is not None else self.sim_dt
        self.n_substeps = whole_ratio(self.ctrl_dt, self.sim_dt, "ctrl_dt", "sim_dt")
        self.robots = {
            n: Robot(self.model, c, ctrl_dt=self.ctrl_dt, data=self.data)
            for n, c in (robots or {}).items()
        }
        if table_height is not None:
            for robot in self.robots.values():
                robot.set_safety_floor(table_height, floor_margin)
        self.objects = {
            n: FreeJointObject(self.model, j, g) for n, (j, g) in (objects or {}).items()
        }
        self.cameras = CameraSet(self.model, camera_names, height, width)
        self.keyframe_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_KEY, keyframe)
        # bound once: the physics of a tick is this one call
        self._physics_step = (
            physics.step if physics is not None else partial(mujoco.mj_step, model, data)
        )

    def reset(self, settle: bool = True) -> None:
        """Keyframe (or model defaults), robots at their initial joints, controls at no-op,
        everything computed (``mj_forward``).

        ``settle=False``: the positions only (``mj_kinematics``), the controls as the
        keyframe has them; for a caller that changes the scene and then holds and forwards
        itself (``TaskSampler.sample_task``: the task's ``reset`` does both).
        """
        if self.keyframe_id >= 0:
            mujoco.mj_resetDataKeyframe(self.model, self.data, self.keyframe_id)
        else:
            mujoco.mj_resetData(self.model, self.data)
        for robot in self.robots.values():
            robot.reset(self.data, hold=settle)
        if settle:
            mujoco.mj_forward(self.model, self.data)
        else:
            mujoco.mj_kinematics(self.model, self.data)

    def forward(self) -> None:
        """``mj_forward``: positions, velocities and forces of the current state, no time step."""
        mujoco.mj_forward(self.model, self.data)

    def apply_control(self) -> None:
        """Let every robot compute and write its control (no physics step)."""
        data = self.data
        for robot in self.robots.values():
            robot.apply_control(data)

    def step(self, n_ctrl_steps: int = 1) -> None:
        """Advance ``n_ctrl_steps`` control ticks; each tick: every robot computes and writes
        its control, then ``n_substeps`` (= ctrl_dt / sim_dt) physics steps."""
        data, n, physics_step, robots = self.data, self.n_substeps, self._physics_step, self.robots
        for _ in range(n_ctrl_steps):
            for robot in robots.values():
                robot.apply_control(data)
            physics_step(n)

    def render_images(self) -> dict[str, np.ndarray]:
        """Images of the configured cameras, uint8 (H, W, 3) by name (the first call opens
        the GL context)."""
        return self.cameras.render_all(self.data)

    def warnings(self) -> list[str]:
        """Names of MuJoCo warnings raised so far (e.g. 'mjWARN_BADQACC')."""
        return [
            mujoco.mjtWarning(i).name
            for i in range(len(self.data.warning))
            if self.data.warning[i].number > 0
        ]

    def close(self) -> None:
        """Release the renderers (GL context); the model and data stay usable."""
        self.cameras.close()
