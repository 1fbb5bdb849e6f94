"""Named cameras rendered offscreen with one renderer reused for every frame.

A ``CameraSet`` opens GL only when an image is asked for (its first render), never at
construction; renderers never closed are closed at interpreter exit, before MuJoCo or
dm_control terminate their EGL display (``sim.closing``). Smaller images get a
proportionally smaller shadow map (:func:`shadow_map_size`), and a process whose first
renderer draws small images (``SMALL_IMAGE``) renders without Mesa's rasterizer threads
(``LP_NUM_THREADS`` set by the user wins). A process forked from one that had opened a GL
context cannot render (a one-line ``UserError``, ``check_can_render``); ``spawn`` and
``forkserver`` children render normally, and state-only envs work anywhere.

Docs: docs/troubleshooting.md; cost: docs/benchmarks.md (Rendering cost).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.names import lookup_id, names_of
from trossen_arm_mujoco.sim.closing import close_at_exit, forget

__all__ = [
    "SHADOW_MAP_IMAGE",
    "SMALL_IMAGE",
    "CameraSet",
    "check_can_render",
    "gl_opened",
    "render_threads",
    "shadow_map_size",
]

_gl_pid: int | None = None  # process that opened a GL context through this module
_forked_from_gl = False  # this process was forked from one with a GL context


def gl_opened() -> bool:
    """Whether this process (or the one it was forked from) has opened a GL context: a
    renderer of this package, or MuJoCo's EGL display."""
    if _gl_pid is not None:
        return True
    egl = sys.modules.get("mujoco.egl")
    return egl is not None and getattr(egl, "EGL_DISPLAY", None) is not None


def _after_fork_in_child() -> None:
    global _forked_from_gl
    _forked_from_gl = _forked_from_gl or gl_opened()


os.register_at_fork(after_in_child=_after_fork_in_child)


def check_can_render() -> None:
    """A UserError when this process was forked from one that had opened a GL context
    (rendering here would hang); nothing otherwise."""
    if _forked_from_gl:
        raise UserError(
            "cannot render in a process forked from one that has rendered (MuJoCo's GL "
            "context does not survive fork); create the envs in fresh processes: "
            'gymnasium.vector.AsyncVectorEnv(env_fns, context="spawn") (or "forkserver"), '
            "or render nothing before forking"
        )


#: Image size (longer side, pixels) the model's shadow map size is meant for.
SHADOW_MAP_IMAGE = 640


def shadow_map_size(model_size: int, height: int, width: int) -> int:
    """Shadow map size for images of ``height`` x ``width``: the model's for 640 pixels,
    proportionally smaller (a power of two, at least 256) for smaller images.

    Args:
        model_size: the model's shadow map size (``visual/quality/shadowsize``).
        height: image height (pixels).
        width: image width (pixels).
    """
    wanted = model_size * max(height, width) / SHADOW_MAP_IMAGE
    size = 256
    while size < wanted:
        size *= 2
    return int(min(model_size, size))


#: Longer image side (pixels) up to which a process's first renderer turns Mesa's rasterizer
#: threads off (``LP_NUM_THREADS=0``): measured cheaper in CPU up to 240x320.
SMALL_IMAGE = 320
#: Mesa's variable for llvmpipe's rasterizer threads, read once, when GL first starts.
THREADS_ENV = "LP_NUM_THREADS"


def render_threads(height: int, width: int) -> str | None:
    """The ``LP_NUM_THREADS`` value a process whose first images are ``height`` x ``width``
    starts GL with: "0" for small images, None (Mesa's default, one a core) otherwise or
    when the user set the variable."""
    if THREADS_ENV in os.environ or max(height, width) > SMALL_IMAGE:
        return None
    return "0"


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
        """Names of every camera of ``model``, in model order."""
        return names_of(model, "camera")

    def check(self, name: str) -> None:
        """A UserError listing the cameras of the set when ``name`` is not one of them."""
        if name not in self.ids:
            raise unknown_name_error("camera", name, self.ids)

    def render(self, data: mujoco.MjData, name: str) -> np.ndarray:
        """One image, uint8 (height, width, 3)."""
        self.check(name)
        if self._renderer is None:
            self._renderer = self._open_renderer()
        self._renderer.update_scene(data, camera=self.ids[name])
        return self._renderer.render()

    def _open_renderer(self) -> mujoco.Renderer:
        global _gl_pid
        check_can_render()
        quality = self.model.vis.quality
        model_size = int(quality.shadowsize)
        quality.shadowsize = shadow_map_size(model_size, self.height, self.width)
        threads = None if _gl_pid is not None else render_threads(self.height, self.width)
        if threads is not None:  # read when GL starts; children get the user's environment
            os.environ[THREADS_ENV] = threads
        try:  # the context reads the shadow map size now; the model keeps its own
            renderer = mujoco.Renderer(self.model, self.height, self.width)
        finally:
            quality.shadowsize = model_size
            if threads is not None:
                os.environ.pop(THREADS_ENV, None)
        _gl_pid = os.getpid()
        close_at_exit(self)
        return renderer

    def render_all(self, data: mujoco.MjData) -> dict[str, np.ndarray]:
        """Images of every camera of the set, by name."""
        return {n: self.render(data, n) for n in self.names}

    def close(self) -> None:
        """Release the renderer (its GL context); rendering again makes a new one."""
        forget(self)
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __del__(self):  # best effort; explicit close() is preferred
        try:
            self.close()
        except Exception:
            pass
