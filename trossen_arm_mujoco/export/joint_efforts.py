"""Joint efforts of recorded kit episodes, derived with MuJoCo's actuator model.

The HDF5 episodes hold positions, velocities and targets, not forces. :func:`derived_efforts`
gives each joint's total motor effort at step ``t`` (``qfrc_actuator`` of the kit's joint
scene at ``qpos[t]``, ``qvel[t]`` under the previous target ``action[t - 1]``: servo force
plus gravity compensation, as the real arm reports it). :func:`derived_external_efforts`
gives what the arms' own model cannot explain (contacts with objects, the table, the other
arm): ``M(q_t) (qvel[t] - predicted) / dt``, zero at ``t = 0`` and in free motion. Both are
``(T, 16)`` in the files' layout: Nm for the arm joints, N for the gripper carriages.

Docs: docs/cli/export.md (joint velocities and efforts); details:
docs/concepts/design-notes.md.
"""

from __future__ import annotations

from functools import lru_cache

import mujoco
import numpy as np

from trossen_arm_mujoco.assets import asset_path
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config
from trossen_arm_mujoco.robot.layout import LAYOUTS

__all__ = ["KIT_SCENE", "derived_efforts", "derived_external_efforts"]

#: The joint-actuated kit scene whose actuators the efforts are of.
KIT_SCENE = "stationary_ai/trossen_ai_scene_joint.xml"

_VENDOR16 = LAYOUTS["vendor16"]


@lru_cache(maxsize=1)
def _kit() -> tuple[mujoco.MjModel, np.ndarray, np.ndarray, dict[str, tuple]]:
    """(model, qpos addresses, dof addresses of the 16 values, group id -> (group, slice))."""
    model = mujoco.MjModel.from_xml_path(str(asset_path(KIT_SCENE)))
    view = stationary_ai_joint_config().build_view(model)
    qpos_idx = np.empty(_VENDOR16.size, dtype=int)
    dof_idx = np.empty(_VENDOR16.size, dtype=int)
    groups = {}
    for name, where in _VENDOR16.groups.items():
        group = view.get_move_group(name)
        qpos_idx[where] = group.qpos_idx
        dof_idx[where] = group.dof_idx
        groups[name] = group
    return model, qpos_idx, dof_idx, groups


def derived_efforts(qpos: np.ndarray, qvel: np.ndarray, action: np.ndarray) -> np.ndarray:
    """Joint efforts of an episode, in the files' 16-value layout (module docstring).

    Args:
        qpos: ``(T, 16)`` recorded joint positions (rad; m for the finger joints).
        qvel: ``(T, 16)`` recorded joint velocities (rad/s; m/s).
        action: ``(T, 16)`` recorded joint targets (rad; m); row ``t - 1`` is the control in
            effect at step ``t``.

    Returns:
        ``(T, 16)`` efforts (Nm; N for the finger joints). The coupled finger's value is its
        share of the gripper force (0 where only gravity compensation acts on it).
    """
    model, qpos_idx, dof_idx, groups = _kit()
    data = mujoco.MjData(model)
    qpos, qvel, action = (np.asarray(a, dtype=np.float64) for a in (qpos, qvel, action))
    out = np.empty_like(qpos)
    for t in range(qpos.shape[0]):
        data.qpos[qpos_idx] = qpos[t]
        data.qvel[dof_idx] = qvel[t]
        _set_targets(data, groups, action[t - 1] if t > 0 else qpos[0])
        mujoco.mj_forward(model, data)
        out[t] = data.qfrc_actuator[dof_idx]
    return out


def derived_external_efforts(
    qpos: np.ndarray, qvel: np.ndarray, action: np.ndarray, dt: float
) -> np.ndarray:
    """External joint efforts of an episode: the generalized force the arms' own model does
    not explain (module docstring), in the files' 16-value layout.

    Args:
        qpos: ``(T, 16)`` recorded joint positions (rad; m for the finger joints).
        qvel: ``(T, 16)`` recorded joint velocities (rad/s; m/s).
        action: ``(T, 16)`` recorded joint targets (rad; m).
        dt: the recording period (s).

    Returns:
        ``(T, 16)`` external efforts (Nm; N for the finger joints); row 0 is zero.
    """
    model, qpos_idx, dof_idx, groups = _kit()
    data = mujoco.MjData(model)
    qpos, qvel, action = (np.asarray(a, dtype=np.float64) for a in (qpos, qvel, action))
    substeps = max(1, round(float(dt) / model.opt.timestep))
    out = np.zeros_like(qpos)
    for t in range(1, qpos.shape[0]):
        mujoco.mj_resetData(model, data)
        data.qpos[qpos_idx] = qpos[t - 1]
        data.qvel[dof_idx] = qvel[t - 1]
        _set_targets(data, groups, action[t - 1])
        mujoco.mj_step(model, data, nstep=substeps)
        predicted = data.qvel[dof_idx].copy()
        data.qpos[qpos_idx] = qpos[t]
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_crb(model, data)
        delta = np.zeros(model.nv)
        delta[dof_idx] = qvel[t] - predicted
        force = np.zeros(model.nv)
        mujoco.mj_mulM(model, data, force, delta)
        out[t] = force[dof_idx] / (substeps * model.opt.timestep)
    return out


def _set_targets(data: mujoco.MjData, groups: dict, target: np.ndarray) -> None:
    """Each move group's control from a ``(16,)`` joint target; a gripper's control is its
    actuated finger (the second of its two values)."""
    for name, group in groups.items():
        values = target[_VENDOR16.groups[name]]
        group.set_ctrl(data, values[-1:] if group.ctrl_dim == 1 else values)
