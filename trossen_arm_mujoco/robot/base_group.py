"""Base groups: where a robot stands. Their ``pose`` is the robot frame of its move groups.

``ImmobileRobotBaseGroup`` (a body fixed to the world; its pose cannot be set),
``MocapRobotBaseGroup`` (a mocap body the robot hangs from, teleported by setting ``pose``),
``FreeJointRobotBaseGroup`` (a body on a free joint; ``pose`` is its 7 qpos) and
``CarriedRobotBaseGroup`` (a body carried by another base, e.g. an arm on a mobile base; its
pose follows the carrier); ``diff_drive.DiffDriveBaseGroup`` drives a free-joint base on two
wheels. Poses are 4x4 transforms of the base frame in the world (m); ``get_pose(data)``
gives [x, y, z, qw, qx, qy, qz].

Docs: docs/concepts/architecture.md (the robot layer), docs/concepts/models.md.
"""

from __future__ import annotations

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.robot.frames import (
    as_transform,
    frame_jacobian,
    pose7_to_transform,
    transform,
    transform_to_pose7,
)
from trossen_arm_mujoco.robot.move_group import MoveGroup

__all__ = [
    "CarriedRobotBaseGroup",
    "FreeJointRobotBaseGroup",
    "ImmobileRobotBaseGroup",
    "MocapRobotBaseGroup",
    "RobotBaseGroup",
]

_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


class RobotBaseGroup(MoveGroup):
    """A move group whose leaf and root frames are the base body's frame: the robot frame.

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "base").
        base_body: the base body (name or id).
        joint_names: the group's joints (a free joint for ``FreeJointRobotBaseGroup``).
    """

    def __init__(self, model, name: str, base_body: str | int, joint_names=()):
        super().__init__(model, name, joint_names, root_body=base_body)
        self.body_id = self.root_body_id
        self.leaf_frame_type = "body"
        self.leaf_frame_id = self.body_id

    @property
    def pose(self) -> np.ndarray:
        """The base frame in the world, 4x4; setting it teleports the robot (where allowed)."""
        return self.get_transform(self.data)

    @pose.setter
    def pose(self, pose) -> None:
        self.set_transform(self.data, pose)

    @property
    def root_frame_to_world(self) -> np.ndarray:
        return self.pose

    @property
    def leaf_frame_to_world(self) -> np.ndarray:
        return self.pose

    def get_transform(self, data: mujoco.MjData) -> np.ndarray:
        """World pose of the base, 4x4."""
        raise NotImplementedError

    def set_transform(self, data: mujoco.MjData, pose) -> None:
        """Put the base at ``pose`` (4x4 or 7 values; kinematics is not recomputed)."""
        raise NotImplementedError

    def get_pose(self, data: mujoco.MjData) -> np.ndarray:
        """World pose of the base, [x, y, z, qw, qx, qy, qz] (m)."""
        return transform_to_pose7(self.get_transform(data))

    def get_jacobian(self) -> np.ndarray:
        """(6, nv) zeros: no dof moves a fixed or mocap base."""
        return np.zeros((6, self.model.nv))


class ImmobileRobotBaseGroup(RobotBaseGroup):
    """A base fixed to the world: no joints, no control, a pose that cannot be set.

    The body and every body above it must be free of joints and not mocap (else a
    UserError names the right base group). Its pose is read from ``data.xpos``/``xmat``:
    valid after ``mj_kinematics``.

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "base").
        base_body: the base body's name.
    """

    def __init__(self, model, name: str, base_body: str):
        super().__init__(model, name, base_body)
        m = self.model
        body = self.body_id
        while body != 0:
            bname = m.body(body).name
            if m.body_mocapid[body] >= 0:
                raise UserError(
                    f"move group '{name}': body '{bname}' is a mocap body; use a mocap base "
                    "(MoveGroupSpec kind 'mocap_base', MocapRobotBaseGroup)"
                )
            if m.body_jntnum[body] > 0:
                raise UserError(
                    f"move group '{name}': base body '{base_body}' moves with the joints of "
                    f"body '{bname}'; an immobile base must be fixed to the world (use a "
                    "free-joint base for a body on a free joint)"
                )
            body = int(m.body_parentid[body])

    def get_transform(self, data):
        return transform(data.xpos[self.body_id], data.xmat[self.body_id])

    def set_transform(self, data, pose) -> None:
        raise UserError(
            f"move group '{self.name}' is an immobile base (fixed to the world in the MJCF): "
            "its pose cannot be set; make the base body a mocap body and use a mocap base "
            "(RobotConfig.with_base_kind('mocap_base'))"
        )


class MocapRobotBaseGroup(RobotBaseGroup):
    """A base on a mocap body: fixed while physics runs, teleported by setting ``pose``.

    The pose is ``data.mocap_pos``/``mocap_quat`` of the body, valid at once (the bodies
    hanging from it follow at the next ``mj_kinematics``).

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "base").
        base_body: the base body's name.
    """

    def __init__(self, model, name: str, base_body: str):
        super().__init__(model, name, base_body)
        self.mocap_id = int(self.model.body_mocapid[self.body_id])
        if self.mocap_id < 0:
            raise UserError(
                f"move group '{name}': body '{base_body}' is not a mocap body; declare it "
                'mocap="true" (a child of the worldbody) or use an immobile base'
            )

    def get_transform(self, data):
        return pose7_to_transform(
            np.concatenate([data.mocap_pos[self.mocap_id], data.mocap_quat[self.mocap_id]])
        )

    def set_transform(self, data, pose) -> None:
        pose7 = transform_to_pose7(as_transform(f"{self.name} pose", pose))
        data.mocap_pos[self.mocap_id] = pose7[:3]
        data.mocap_quat[self.mocap_id] = pose7[3:]


class FreeJointRobotBaseGroup(RobotBaseGroup):
    """A base body on a free joint: ``joint_pos`` is its 7 qpos [x, y, z, qw, qx, qy, qz],
    ``joint_vel`` its 6 dofs; setting ``pose`` writes the qpos (velocities are kept).

    Args:
        free_joint: the free joint; the base body is the body it moves.
    """

    joint_types = (_FREE,)

    def __init__(self, model, name: str, free_joint: str):
        source = model
        m = model.model if isinstance(model, mujoco.MjData) else model
        jid = lookup_id(m, "joint", free_joint)
        if int(m.jnt_type[jid]) != _FREE:
            raise UserError(f"move group '{name}': joint '{free_joint}' is not a free joint")
        super().__init__(source, name, int(m.jnt_bodyid[jid]), joint_names=[free_joint])

    def get_transform(self, data):
        q = data.qpos[self.qpos_idx]
        return pose7_to_transform(q)

    def set_transform(self, data, pose) -> None:
        data.qpos[self.qpos_idx] = transform_to_pose7(as_transform(f"{self.name} pose", pose))

    def get_jacobian(self) -> np.ndarray:
        """(6, nv) Jacobian of the base body's origin (its free joint moves it)."""
        return frame_jacobian(self.model, self.data, "body", self.body_id)


class CarriedRobotBaseGroup(RobotBaseGroup):
    """A base rigidly carried by a moving body: an arm's mount on a mobile base.

    No joint lies between the body and the first body above it that moves (on a free
    joint); its pose is read from ``data.xpos``/``xmat`` (valid after ``mj_kinematics``) and
    changes only with the carrier's (``Robot.set_world_pose`` moves the carrier; setting
    this pose alone is a UserError).

    Args:
        model: compiled model, or an ``MjData`` to bind to at once.
        name: group name (e.g. "base").
        base_body: the base body's name.
    """

    def __init__(self, model, name: str, base_body: str):
        super().__init__(model, name, base_body)
        m = self.model
        body = self.body_id
        while body != 0:
            if m.body_mocapid[body] >= 0:
                raise UserError(
                    f"move group '{name}': body '{m.body(body).name}' is a mocap body; use a "
                    "mocap base"
                )
            types = m.jnt_type[m.body_jntadr[body] : m.body_jntadr[body] + m.body_jntnum[body]]
            if len(types) and (len(types) > 1 or int(types[0]) != _FREE):
                raise UserError(
                    f"move group '{name}': base body '{base_body}' moves with the joints of "
                    f"body '{m.body(body).name}'; a carried base hangs rigidly from a body on "
                    "a free joint"
                )
            if len(types):
                self.carrier_body_id = body
                return
            body = int(m.body_parentid[body])
        raise UserError(
            f"move group '{name}': base body '{base_body}' is fixed to the world; use an "
            "immobile base (kind 'base')"
        )

    def get_transform(self, data):
        return transform(data.xpos[self.body_id], data.xmat[self.body_id])

    def set_transform(self, data, pose) -> None:
        raise UserError(
            f"move group '{self.name}' is carried by body "
            f"'{self.model.body(self.carrier_body_id).name}': move that base instead "
            "(robot.set_world_pose)"
        )
