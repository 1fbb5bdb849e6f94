"""Per-link safety floor: every collision geom of an arm kept above the table.

``SafetyFloor`` looks up, once, every collision geom of each arm: the geoms of the bodies
that move with the arm's joints (the subtree of its first joint's body: links, wrist,
fingers; not the fixed base). Each geom becomes a few points in its body's frame with a
radius, whose lowest world point is the geom's lowest point:

- box, mesh: its corners / vertices (exact);
- sphere, capsule: centre / the two axis end points, with the radius (exact);
- cylinder: two 16-gons circumscribing its end discs (at most 0.8 % of the radius low);
- ellipsoid, and any other type: the corners of its bounding box (conservative).

The arm's tool-frame site is one more point (radius 0), so the floor also keeps the tool
frame up, as the tool-frame-only floor did. ``lowest(qpos, arm, q)`` runs forward kinematics
on a private ``MjData`` (the caller's data is never written) and returns the lowest point
(world z, m) and the link it belongs to.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

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


def _as_slice(idx: np.ndarray) -> slice | np.ndarray:
    """A slice for consecutive indices (cheaper to read and write through), else them."""
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


class _ArmPoints:
    """Points of one arm in its bodies' frames, as one matrix: the lowest point is one
    product with the bodies' poses.

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
        self.body_sel = _as_slice(self.bodies)
        self.qpos_sel = _as_slice(np.asarray(group.qpos_idx, dtype=int))

    def lowest(self, data: mujoco.MjData) -> tuple[float, int]:
        """(lowest world z (m), body id of that point) at ``data``'s body poses."""
        per_body, sel = self._per_body, self.body_sel
        per_body[:, :3] = data.xmat[sel, 6:9]
        per_body[:, 3] = data.xpos[sel, 2]
        z = self.matrix @ self.vector
        i = int(z.argmin())
        return float(z[i]), int(self.owner[i])


class SafetyFloor:
    """Lowest points of arms at candidate joint positions.

    Args:
        model: compiled model.
        arms: the arm move groups (joint-actuated, first joint nearest the base).
        floor_z: lowest allowed height (m, world z): ``table_height + safety_margin``.
    """

    def __init__(self, model: mujoco.MjModel, arms: Sequence, floor_z: float):
        self.model = model
        self.floor_z = float(floor_z)
        self.arms = {arm.name: _ArmPoints(model, arm) for arm in arms}
        self._data = mujoco.MjData(model)

    def lowest(
        self, qpos_full: np.ndarray, arm: str, q: np.ndarray | None = None
    ) -> tuple[float, int]:
        """(lowest world z (m) of ``arm``'s collision geoms and tool frame, body id of that
        point) at ``qpos_full`` (nq,) with the arm's joints replaced by ``q`` (rad)."""
        pts = self.arms[arm]
        data = self._data
        data.qpos[:] = qpos_full
        if q is not None:
            data.qpos[pts.qpos_sel] = q
        mujoco.mj_kinematics(self.model, data)
        return pts.lowest(data)

    def link_name(self, body: int) -> str:
        return mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}"
