"""Named cameras rendered offscreen with one renderer reused for every frame."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.names import lookup_id, names_of


class CameraSet:
    """Renders a fixed list of model cameras at one resolution.

    The GL context and renderer are created on the first render and reused until
    ``close()``; no context is ever created per frame.

    Args:
        model: compiled model.
        camera_names: cameras to render (validated here, at construction).
        height, width: image size in pixels (at most the model's offscreen buffer).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        camera_names: Sequence[str],
        height: int = 480,
        width: int = 640,
    ):
        self.model = model
        self.names = list(camera_names)
        self.ids = {n: lookup_id(model, "camera", n) for n in self.names}
        if height <= 0 or width <= 0:
            raise UserError(f"image size must be positive, got {height}x{width}")
        if height > model.vis.global_.offheight or width > model.vis.global_.offwidth:
            raise UserError(
                f"image size {height}x{width} exceeds the model's offscreen buffer "
                f"{model.vis.global_.offheight}x{model.vis.global_.offwidth}"
            )
        self.height, self.width = height, width
        self._renderer: mujoco.Renderer | None = None

    @staticmethod
    def available(model: mujoco.MjModel) -> list[str]:
        return names_of(model, "camera")

    def check(self, name: str) -> None:
        if name not in self.ids:
            raise unknown_name_error("camera", name, self.ids)

    def render(self, data: mujoco.MjData, name: str) -> np.ndarray:
        """One image, uint8 (height, width, 3)."""
        self.check(name)
        if self._renderer is None:
            self._renderer = mujoco.Renderer(self.model, self.height, self.width)
        self._renderer.update_scene(data, camera=self.ids[name])
        return self._renderer.render()

    def render_all(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Images of every camera of the set, by name."""
        return {n: self.render(data, n) for n in self.names}

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __del__(self):  # best effort; explicit close() is preferred
        try:
            self.close()
        except Exception:
            pass
