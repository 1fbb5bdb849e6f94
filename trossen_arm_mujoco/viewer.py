"""Live display: a passive MuJoCo viewer window (with camera thumbnails) when a display exists.

Without a display (no DISPLAY, or GLFW cannot open a window) ``LiveViewer.open`` returns None
and says why once; callers carry on headless. Starting never hangs (a timeout guards
``launch_passive``) and closing waits for the viewer's threads, since exiting while the render
thread still swaps buffers can crash Xlib.

Docs: docs/troubleshooting.md.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import warnings

import mujoco
import numpy as np

__all__ = [
    "VIEWER_START_TIMEOUT_S",
    "LiveViewer",
    "close_viewer",
    "display_problem",
    "launch_viewer",
]

#: Seconds to wait for the viewer window before giving up.
VIEWER_START_TIMEOUT_S = 20.0


def display_problem(probe_window: bool = True) -> str | None:
    """None when a live window can be opened, else why not (one short phrase).

    ``probe_window=False`` only initialises GLFW (no probe window, GLFW left initialised):
    needed where this process also renders offscreen, since a GLX probe window made and
    destroyed here breaks the viewer's context (X_GLXMakeCurrent BadAccess).
    """
    if not os.environ.get("DISPLAY"):
        return "no DISPLAY"
    try:
        import glfw
    except Exception as exc:  # missing package or GLFW library
        return f"GLFW unavailable ({exc})"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            if not glfw.init():
                return f"glfw.init() failed on DISPLAY={os.environ['DISPLAY']}"
            if not probe_window:
                return None
            try:
                glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
                window = glfw.create_window(64, 64, "probe", None, None)
                if not window:
                    return "cannot create an OpenGL window"
                glfw.destroy_window(window)
            finally:
                glfw.default_window_hints()
                glfw.terminate()
        except Exception as exc:
            return f"GLFW error ({exc})"
    return None


def launch_viewer(model, data, timeout: float | None = VIEWER_START_TIMEOUT_S):
    """``mujoco.viewer.launch_passive`` that gives up after ``timeout`` s instead of hanging
    (it waits forever when its window thread fails).

    Args:
        model: compiled model.
        data: the state shown.
        timeout: seconds to wait for the window (None: forever).

    Returns:
        (handle, threads): the threads the viewer started, to join after ``close()``.
    """
    import mujoco.viewer

    before = set(threading.enumerate())
    if timeout is None:  # in this thread (needed when this thread renders offscreen too)
        handle = mujoco.viewer.launch_passive(model, data, show_left_ui=False, show_right_ui=False)
        return handle, [t for t in threading.enumerate() if t not in before]
    result: dict = {}

    def target() -> None:
        try:
            result["handle"] = mujoco.viewer.launch_passive(
                model, data, show_left_ui=False, show_right_ui=False
            )
        except BaseException as exc:  # reported to the caller below
            result["error"] = exc

    thread = threading.Thread(target=target, name="viewer-launch", daemon=True)
    thread.start()
    thread.join(timeout)
    if "error" in result:
        raise RuntimeError(f"viewer failed to start: {result['error']}")
    if "handle" not in result:
        raise RuntimeError(f"viewer did not open within {timeout:g} s")
    started = [t for t in threading.enumerate() if t not in before and t is not thread]
    return result["handle"], started


def close_viewer(viewer, threads: list[threading.Thread], timeout: float = 10.0) -> None:
    """Close the window and wait for the viewer's threads to finish: exiting while the
    render thread still swaps buffers can crash Xlib (GLXBadDrawable).

    Args:
        viewer: the viewer handle.
        threads: the threads :func:`launch_viewer` returned.
        timeout: seconds to wait for each thread.
    """
    viewer.close()
    deadline = time.monotonic() + timeout
    for t in threads:
        t.join(max(0.0, deadline - time.monotonic()))


class LiveViewer:
    """A passive viewer on (model, data); ``update()`` after each step redraws it.

    Camera images passed to ``update`` are shown as thumbnails along the bottom edge.

    Args:
        handle: the passive viewer (:func:`launch_viewer`).
        threads: its threads.
        thumb_stride: thumbnails keep every ``thumb_stride``-th row and column.
    """

    def __init__(self, handle, threads: list[threading.Thread], thumb_stride: int = 4):
        self.handle = handle
        self.threads = threads
        self.thumb_stride = thumb_stride

    @classmethod
    def open(cls, model: mujoco.MjModel, data: mujoco.MjData) -> LiveViewer | None:
        """A passive MuJoCo viewer of ``model`` / ``data``, or None (with a note on
        stderr) when no window can be opened."""
        problem = display_problem(probe_window=False)
        if problem:
            print(f"live view off: {problem}; continuing headless", file=sys.stderr)
            return None
        try:
            # Launched from this thread: a GLX context made in a helper thread clashes with
            # this thread's offscreen rendering (X_GLXMakeCurrent BadAccess).
            handle, threads = launch_viewer(model, data, timeout=None)
        except Exception as exc:
            print(f"live view off: {exc}; continuing headless", file=sys.stderr)
            return None
        return cls(handle, threads)

    def is_running(self) -> bool:
        """Whether the viewer window is still open."""
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
        except Exception:  # viewers without overlays: 3D view only
            pass

    def close(self) -> None:
        """Close the window and stop its threads; errors while closing are ignored."""
        try:
            close_viewer(self.handle, self.threads)
        except Exception:
            pass
