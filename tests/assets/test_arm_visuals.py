"""The arm's own visual shapes: drawing only, and sized like the real links."""

from __future__ import annotations

import itertools
from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR

ARM = Path(ASSETS_DIR) / "wxai/wxai_follower.xml"
KIT = Path(ASSETS_DIR) / "stationary_ai/trossen_ai.xml"
# Bounding boxes (body frame, m) of the vendor's link meshes (facts sheet C1; link_6 with the
# camera mount, each carriage with its finger).
VENDOR_AABB = {
    "base_link": ((-0.0325, -0.0325, 0.0), (0.037218, 0.0325, 0.06025)),
    "link_1": ((-0.028985, -0.041325, 0.0), (0.037387, 0.048325, 0.06375)),
    "link_2": ((-0.2925, -0.036325, -0.0285), (0.0285, 0.036325, 0.035342)),
    "link_3": ((-0.0175, -0.041325, -0.0175), (0.2735, 0.041325, 0.0885)),
    "link_4": ((-0.017495, -0.0377, -0.017491), (0.09625, 0.0437, 0.1015)),
    "link_5": ((-0.040256, -0.0285, -0.092178), (0.02895, 0.0285, 0.0)),
    "link_6": ((0.0, -0.0933, -0.0308), (0.0825, 0.0933, 0.085196)),
    "carriage_right": ((-0.0185, -0.01445, -0.03), (0.069562, 0.07725, 0.029936)),
    "carriage_left": ((-0.0185, -0.07725, -0.03), (0.069562, 0.01445, 0.029936)),
}
MARGIN = 0.003  # m
#: The carriages' long belt clamps run inside the rail housing and are not drawn.
UNDRAWN = {("carriage_right", 1), ("carriage_left", 1)}


def geom_vertices(model: mujoco.MjModel, g: int) -> np.ndarray:
    """Vertices (or bounding-box corners) of geom ``g`` in its body frame."""
    size, kind = model.geom_size[g], mujoco.mjtGeom(model.geom_type[g])
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = model.geom_dataid[g]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        local = model.mesh_vert[start : start + count]
    else:
        half = {mujoco.mjtGeom.mjGEOM_BOX: size, mujoco.mjtGeom.mjGEOM_CYLINDER: size[[0, 0, 1]]}
        local = np.array(list(itertools.product(*[(-h, h) for h in half[kind]])))
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, model.geom_quat[g])
    return model.geom_pos[g] + local @ rot.reshape(3, 3).T


def visual_geoms(model: mujoco.MjModel, body: str) -> list[int]:
    bid = model.body(body).id
    return [
        g for g in range(model.ngeom) if model.geom_bodyid[g] == bid and model.geom_group[g] == 2
    ]


@pytest.mark.parametrize("xml", [ARM, KIT], ids=["arm", "kit"])
def test_visuals_never_collide(xml):
    model = mujoco.MjModel.from_xml_path(str(xml))
    drawn = model.geom_group == 2
    assert drawn.sum() >= 2 * len(VENDOR_AABB)
    assert not model.geom_contype[drawn].any() and not model.geom_conaffinity[drawn].any()


@pytest.mark.parametrize("body", VENDOR_AABB)
def test_visuals_are_sized_like_the_real_links(body):
    model = mujoco.MjModel.from_xml_path(str(ARM))
    verts = np.concatenate([geom_vertices(model, g) for g in visual_geoms(model, body)])
    lo, hi = (np.asarray(v) for v in VENDOR_AABB[body])
    assert np.all(verts.min(axis=0) >= lo - MARGIN) and np.all(verts.max(axis=0) <= hi + MARGIN)
    cover = (verts.max(axis=0) - verts.min(axis=0)) / (hi - lo)
    for axis in range(3):
        if (body, axis) not in UNDRAWN:
            assert cover[axis] > 0.8, (axis, cover)
