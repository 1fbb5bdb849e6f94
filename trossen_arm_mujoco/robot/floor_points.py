"""Points of an arm's collision geoms, whose lowest world point is the arm's lowest point.

Used by the safety floor (``robot.safety_floor``). ``ArmPoints`` turns every collision geom
of the bodies that move with one arm's joints (links, wrist, fingers; not the fixed base)
into a few points in its body's frame with a radius, plus the tool-frame site (radius 0):
exact for boxes, meshes, spheres and capsules, within 0.8 % of the radius for cylinders,
conservative (bounding box) for the rest. ``ArmPoints.heights(data)`` is the world z (m) of
every point's lowest reach at ``data``'s body poses. ``reach[p, i]`` bounds how far point p
moves per radian of joint i; points no joint moves up or down (``fixed_height``) are not
checked.

Docs: docs/concepts/design-notes.md.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.robot.selection import as_slice

__all__ = ["CYLINDER_SIDES", "ArmPoints", "geom_points"]

#: Sides of the polygons standing in for cylinder end discs.
CYLINDER_SIDES = 16


def _box_corners(half: np.ndarray) -> np.ndarray:
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return signs * half


def geom_points(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, float]:
    """Points (k, 3) in the geom's frame and a radius whose Minkowski sum covers the geom."""
    kind = mujoco.mjtGeom(int(model.geom_type[geom]))
    size = model.geom_size[geom]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return _box_corners(size), 0.0
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return np.zeros((1, 3)), float(size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return np.array([[0.0, 0.0, -size[1]], [0.0, 0.0, size[1]]]), float(size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        angles = 2 * np.pi * np.arange(CYLINDER_SIDES) / CYLINDER_SIDES
        rim = size[0] / np.cos(np.pi / CYLINDER_SIDES)  # polygon around the circle
        ring = np.stack([rim * np.cos(angles), rim * np.sin(angles)], axis=1)
        ends = [np.column_stack([ring, np.full(CYLINDER_SIDES, z)]) for z in (-size[1], size[1])]
        return np.concatenate(ends), 0.0
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[geom])
        start, n = int(model.mesh_vertadr[mesh]), int(model.mesh_vertnum[mesh])
        return model.mesh_vert[start : start + n].astype(np.float64), 0.0
    aabb = model.geom_aabb[geom]  # [centre (3), half sizes (3)] in the geom frame
    return aabb[:3] + _box_corners(aabb[3:]), 0.0


def _subtree(model: mujoco.MjModel, root: int) -> list[int]:
    """Bodies of the subtree rooted at ``root`` (itself included)."""
    out = []
    for body in range(model.nbody):
        b = body
        while b > 0 and b != root:
            b = int(model.body_parentid[b])
        if b == root:
            out.append(body)
    return out


class ArmPoints:
    """Points of one arm in its bodies' frames, as one matrix: the lowest point is one
    product with the bodies' poses.

    Args:
        model: compiled model.
        group: the arm's move group (``joint_ids`` with the first joint nearest the base,
            ``qpos_idx``, ``dof_idx``; ``frame_site_id`` when it has a tool frame).

    ``matrix`` (N, 4K + 1): row of point p (of the k-th body) holds [p (3), 1] in columns
    4k..4k+3 and -radius in the last, so that ``matrix @ v`` with v = [per body: third row
    of its rotation (3), its z (1); then 1] is the world z of every point's lowest reach.
    """

    def __init__(self, model: mujoco.MjModel, group) -> None:
        root = int(model.jnt_bodyid[group.joint_ids[0]])
        self.bodies = np.array(_subtree(model, root), dtype=int)
        column = {int(b): k for k, b in enumerate(self.bodies)}
        rows, owners = [], []
        for g in range(model.ngeom):
            body = int(model.geom_bodyid[g])
            if body not in column or not (model.geom_contype[g] or model.geom_conaffinity[g]):
                continue
            local, radius = geom_points(model, g)
            rot = np.empty(9)
            mujoco.mju_quat2Mat(rot, model.geom_quat[g])
            for point in model.geom_pos[g] + local @ rot.reshape(3, 3).T:
                rows.append((column[body], point, radius))
        site = getattr(group, "frame_site_id", None)
        if site is not None:
            rows.append((column[int(model.site_bodyid[site])], model.site_pos[site], 0.0))
        k_bodies = len(self.bodies)
        self.matrix = np.zeros((len(rows), 4 * k_bodies + 1))
        for r, (k, point, radius) in enumerate(rows):
            self.matrix[r, 4 * k : 4 * k + 3] = point
            self.matrix[r, 4 * k + 3] = 1.0
            self.matrix[r, -1] = -radius
            owners.append(int(self.bodies[k]))
        self.owner = np.array(owners, dtype=int)
        self.vector = np.zeros(4 * k_bodies + 1)
        self.vector[-1] = 1.0
        self._per_body = self.vector[:-1].reshape(k_bodies, 4)  # a view: filled in place
        self.body_sel = as_slice(self.bodies)
        self.qpos_sel = as_slice(np.asarray(group.qpos_idx, dtype=int))
        self.dof_sel = as_slice(np.asarray(group.dof_idx, dtype=int))
        self.reach = _joint_reach(model, group.joint_ids, self.bodies, self.matrix, self.owner)
        #: points no arm joint moves up or down (their height never changes)
        self.fixed_height = ~self.reach.any(axis=1)
        # the rows of the points that can move up or down (fixed ones never break the floor)
        self.moving_matrix = self.matrix[~self.fixed_height]

    def _load(self, xmat: np.ndarray, xpos: np.ndarray) -> np.ndarray:
        """``vector`` filled from the body poses ``xmat`` (nbody, 9) and ``xpos`` (nbody, 3)
        of an ``MjData``."""
        per_body, sel = self._per_body, self.body_sel
        per_body[:, :3] = xmat[sel, 6:9]
        per_body[:, 3] = xpos[sel, 2]
        return self.vector

    def heights(self, data: mujoco.MjData) -> np.ndarray:
        """World z (m) of every point's lowest reach at ``data``'s body poses, (N,)."""
        return self.matrix.dot(self._load(data.xmat, data.xpos))

    def moving_heights(self, data: mujoco.MjData) -> np.ndarray:
        """``heights`` of the points an arm joint can move up or down, (M,)."""
        return self.moving_heights_at(data.xmat, data.xpos)

    def moving_heights_at(self, xmat: np.ndarray, xpos: np.ndarray) -> np.ndarray:
        """``moving_heights`` from the body poses ``xmat`` (nbody, 9) and ``xpos``
        (nbody, 3) of an ``MjData`` (views taken once by a caller that reads them often)."""
        return self.moving_matrix.dot(self._load(xmat, xpos))


def _joint_reach(
    model: mujoco.MjModel,
    joint_ids: Sequence[int],
    bodies: np.ndarray,
    matrix: np.ndarray,
    owner: np.ndarray,
) -> np.ndarray:
    """(N points, n joints): an upper bound (m) on how far each point of ``matrix`` moves per
    radian of each arm joint, valid in every configuration; 0 where the joint does not move
    the point.

    A hinge moves a point along an arc whose radius is at most the point's distance from the
    joint anchor, which is at most the sum of the body offsets along the chain between them
    (plus the travel of any slide joint on the way), the point's offset in its body and its
    radius. A first joint whose axis is the world's vertical, on a fixed base, moves nothing
    up or down: its column is 0.
    """
    column = {int(b): k for k, b in enumerate(bodies)}
    extent = np.empty(len(owner))
    for r, body in enumerate(owner):
        k = column[int(body)]
        extent[r] = np.linalg.norm(matrix[r, 4 * k : 4 * k + 3]) - matrix[r, -1]
    reach = np.zeros((len(owner), len(joint_ids)))
    for i, joint in enumerate(joint_ids):
        joint_body = int(model.jnt_bodyid[joint])
        if _vertical_on_fixed_base(model, joint):
            continue
        to_body = {joint_body: float(np.linalg.norm(model.jnt_pos[joint]))}
        for body in bodies:  # in id order: parents before children
            body = int(body)
            parent = int(model.body_parentid[body])
            if body == joint_body or parent not in to_body:
                continue
            first = int(model.body_jntadr[body])
            joints = range(first, first + int(model.body_jntnum[body]))
            travel = sum(
                float(np.abs(model.jnt_range[j]).max())
                for j in joints
                if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE
            )
            to_body[body] = to_body[parent] + float(np.linalg.norm(model.body_pos[body])) + travel
        for r, body in enumerate(owner):
            if int(body) in to_body:
                reach[r, i] = to_body[int(body)] + extent[r]
    return reach


def _vertical_on_fixed_base(model: mujoco.MjModel, joint: int) -> bool:
    """A hinge about the world z axis whose body has no moving ancestor (and upright frames
    up to the world), so that turning it changes no height."""
    if model.jnt_type[joint] != mujoco.mjtJoint.mjJNT_HINGE:
        return False
    body = int(model.jnt_bodyid[joint])
    if int(model.body_jntadr[body]) != joint:  # another joint of the body comes first
        return False
    rot = np.eye(3)
    b = body
    while b > 0:
        if b != body and model.body_jntnum[b]:
            return False
        if model.body_mocapid[b] >= 0:
            return False
        frame = np.empty(9)
        mujoco.mju_quat2Mat(frame, model.body_quat[b])
        rot = frame.reshape(3, 3) @ rot
        b = int(model.body_parentid[b])
    axis = rot @ model.jnt_axis[joint]
    return bool(abs(abs(axis[2]) - 1.0) < 1e-9)
