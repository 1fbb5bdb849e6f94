"""Leave out of a camera's frame the geoms it can neither see nor see the shadow of.

MuJoCo's renderer draws every visible geom of the model in every pass (the shadow-casting
light's depth pass and the lit passes) whatever the camera looks at. With software
rendering that is most of a small frame's cost (docs/benchmarks.md, "Rendering cost"): a
camera looking at the middle of the table still pays for both arms' 46 meshes. ``ViewCull``
hides, for one render, each geom whose bounding sphere lies outside the camera's view
pyramid and whose shadow cannot fall into it either; the frame is the same pixels
(tested against the unculled frame, ``tests/sim/test_view_cull.py``).

A geom is kept when the capsule swept by its bounding sphere from its centre along each
shadow-casting light's direction down to the lowest geom of the scene touches the view
pyramid (the shadow test is skipped when the scene draws no shadows). Planes, height
fields and anything without a finite bounding sphere are always drawn; a model with a
reflective material is never culled (a mirror shows what the camera does not face).

Hiding works through the geom's group: for the second ``mjv_updateScene`` of the frame,
hidden geoms are moved to a group the render options leave off, and moved back right after
(no physics quantity reads ``geom_group``).
"""

from __future__ import annotations

import mujoco
import numpy as np

__all__ = ["ViewCull"]

_MARGIN = 1e-3  # metres added to every bounding sphere (rounding of the GL camera's floats)
_SWEEP_UP = 4.0  # sweep length, in scene extents, for a light that does not point down


def _directional(model: mujoco.MjModel, light: int) -> bool:
    """Whether ``light`` shines along one direction (MuJoCo >= 3.3 names it ``light_type``)."""
    if hasattr(model, "light_type"):
        return int(model.light_type[light]) == int(mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    return bool(model.light_directional[light])


class ViewCull:
    """Per-frame culling of one model's geoms against a camera's view (and its shadows).

    Args:
        model: the compiled model the renderer draws (its ``geom_group`` is changed during
            :meth:`update_scene` only).
        option: the render options the renderer uses (their ``geomgroup`` says which groups
            are drawn); MuJoCo's defaults when None.
    """

    def __init__(self, model: mujoco.MjModel, option: mujoco.MjvOption | None = None):
        self.model = model
        option = option if option is not None else mujoco.MjvOption()
        groups = np.asarray(option.geomgroup, dtype=bool)
        off = np.flatnonzero(~groups)
        shown = groups[np.clip(model.geom_group, 0, groups.size - 1)]
        finite = (model.geom_rbound > 0) & ~np.isin(
            model.geom_type, (mujoco.mjtGeom.mjGEOM_PLANE, mujoco.mjtGeom.mjGEOM_HFIELD)
        )
        #: False where no group is left off to hide geoms in (nothing is culled)
        self.enabled = bool(off.size)
        self._hidden_group = int(off[-1]) if off.size else 0
        self._shown = np.flatnonzero(shown)  # geoms the options draw
        self._candidates = np.flatnonzero(shown & finite)

    def update_scene(
        self,
        renderer: mujoco.Renderer,
        data: mujoco.MjData,
        camera: int,
    ) -> int:
        """``renderer.update_scene(data, camera)`` without the geoms the view does not need.

        Returns:
            how many geoms were left out of the scene.
        """
        renderer.update_scene(data, camera=camera)
        model = self.model  # read at every frame: randomization changes looks and sizes
        if not self.enabled or not self._candidates.size or np.any(model.mat_reflectance > 0):
            return 0
        self._radius = model.geom_rbound[self._candidates] + _MARGIN
        shadow_lights = np.flatnonzero(model.light_castshadow)
        scene = renderer.scene
        # the frame is drawn from the average of the two eyes' cameras (each ipd/2 aside)
        eye = mujoco.mjv_averageCamera(scene.camera[0], scene.camera[1])
        normals, apex = self._view_planes(eye, renderer.width / renderer.height)
        keep = self._touches(data.geom_xpos[self._candidates], normals, apex, self._radius)
        if scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] and shadow_lights.size:
            for light in shadow_lights:
                keep |= self._shadow_touches(data, int(light), normals, apex, ~keep)
        hidden = self._candidates[~keep]
        if not hidden.size:
            return 0
        groups = model.geom_group
        saved = groups[hidden].copy()
        groups[hidden] = self._hidden_group
        try:
            renderer.update_scene(data, camera=camera)
        finally:
            groups[hidden] = saved
        return int(hidden.size)

    @staticmethod
    def _view_planes(gl_camera, aspect: float) -> tuple[np.ndarray, np.ndarray]:
        """Inward unit normals (4, 3) of the view pyramid's side planes (world frame) and its
        apex (3,), from MuJoCo's GL camera and the image's width / height."""
        fx, fy, fz = gl_camera.forward
        ux, uy, uz = gl_camera.up
        # rows: the camera's right, up and forward axes in the world frame
        axes = np.array(
            [(fy * uz - fz * uy, fz * ux - fx * uz, fx * uy - fy * ux), (ux, uy, uz), (fx, fy, fz)]
        )
        bottom, top = gl_camera.frustum_bottom, gl_camera.frustum_top
        half = gl_camera.frustum_width or 0.5 * aspect * (top - bottom)
        left, right = gl_camera.frustum_center - half, gl_camera.frustum_center + half
        near = gl_camera.frustum_near
        # in the camera frame a point (x, y, z) is inside when left <= near x / z <= right and
        # bottom <= near y / z <= top (z along forward)
        local = np.array(
            [(near, 0.0, -left), (-near, 0.0, right), (0.0, near, -bottom), (0.0, -near, top)]
        )
        local /= np.linalg.norm(local, axis=1, keepdims=True)
        return local @ axes, np.array(gl_camera.pos, dtype=float)

    @staticmethod
    def _touches(
        centers: np.ndarray, normals: np.ndarray, apex: np.ndarray, radius: np.ndarray
    ) -> np.ndarray:
        """(G,) True where the sphere (centre, radius) is not wholly outside a side plane."""
        distance = (centers - apex) @ normals.T  # (G, 4)
        return np.all(distance >= -radius[:, None], axis=1)

    def _shadow_touches(
        self,
        data: mujoco.MjData,
        light: int,
        normals: np.ndarray,
        apex: np.ndarray,
        todo: np.ndarray,
    ) -> np.ndarray:
        """(G,) True where the sphere swept along ``light``'s rays reaches the view."""
        result = np.zeros(self._candidates.size, dtype=bool)
        if not np.any(todo):
            return result
        centers = data.geom_xpos[self._candidates[todo]]
        shown = self._shown
        lowest = float(np.min(data.geom_xpos[shown, 2] - self.model.geom_rbound[shown]))
        if _directional(self.model, light):
            rays = np.broadcast_to(data.light_xdir[light], centers.shape)
        else:
            rays = centers - data.light_xpos[light]
        rays = rays / np.maximum(np.linalg.norm(rays, axis=1, keepdims=True), 1e-12)
        down = -rays[:, 2]
        drop = centers[:, 2] - lowest + self._radius[todo]
        length = np.where(
            down > 1e-6,
            drop / np.maximum(down, 1e-6),
            _SWEEP_UP * self.model.stat.extent,
        )
        ends = centers + rays * length[:, None]
        radius = self._radius[todo][:, None]
        start = (centers - apex) @ normals.T
        end = (ends - apex) @ normals.T
        outside = (start < -radius) & (end < -radius)  # both ends beyond one plane
        result[todo] = ~np.any(outside, axis=1)
        return result
