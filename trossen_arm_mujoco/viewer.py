"""Live display: a passive MuJoCo viewer window with camera thumbnails, when a display exists.

Without a display (no DISPLAY / WAYLAND_DISPLAY, or GLFW cannot start) ``LiveViewer.open``
returns None and says why once; callers carry on headless. Nothing here blocks.
"""

from __future__ import annotations

import os
import sys

import mujoco
import numpy as np


def display_available() -> tuple[bool, str]:
    """(True, "") when a window can be opened, else (False, reason)."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        return False, "no display (DISPLAY is not set)"
    try:
        import glfw

        if not glfw.init():
            return False, "GLFW could not initialise the display"
    except Exception as exc:  # missing libs, broken X server
        return False, f"GLFW unavailable: {exc}"
    return True, ""


class LiveViewer:
    """A passive viewer on (model, data); ``update()`` after each step redraws it.

    Camera images passed to ``update`` are shown as thumbnails along the bottom edge.
    """

    def __init__(self, handle, thumb_stride: int = 4):
        self.handle = handle
        self.thumb_stride = thumb_stride

    @classmethod
    def open(cls, model: mujoco.MjModel, data: mujoco.MjData) -> LiveViewer | None:
        ok, why = display_available()
        if not ok:
            print(f"live view off: {why}; continuing headless", file=sys.stderr)
            return None
        try:
            import mujoco.viewer

            handle = mujoco.viewer.launch_passive(
                model, data, show_left_ui=False, show_right_ui=False
            )
        except Exception as exc:
            print(f"live view off: {exc}; continuing headless", file=sys.stderr)
            return None
        return cls(handle)

    def is_running(self) -> bool:
        return bool(self.handle.is_running())

    def update(self, images: dict[str, np.ndarray] | None = None) -> bool:
        """Redraw; returns False once the window was closed."""
        if not self.handle.is_running():
            return False
        if images:
            self._show_thumbnails(images)
        self.handle.sync()
        return True

    def _show_thumbnails(self, images: dict[str, np.ndarray]) -> None:
        rects = []
        x = 0
        for img in images.values():
            thumb = np.ascontiguousarray(img[:: self.thumb_stride, :: self.thumb_stride])
            h, w = thumb.shape[:2]
            rects.append((mujoco.MjrRect(x, 0, w, h), thumb))
            x += w + 4
        try:
            self.handle.set_images(rects)
        except Exception:  # older viewers without overlays: 3D view only
            pass

    def close(self) -> None:
        try:
            self.handle.close()
        except Exception:
            pass
