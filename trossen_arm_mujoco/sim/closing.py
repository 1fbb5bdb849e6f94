"""Close what holds GL resources (renderers, viewer windows) when the interpreter exits.

MuJoCo and dm_control terminate their EGL display from ``atexit`` callbacks, registered when
they open it, possibly after this package's first renderer; a renderer freed after that fails
with "Exception ignored ... EGLError" tracebacks, and a viewer window whose render thread is
still drawing at exit can crash Xlib. threading's exit hooks run before every ``atexit``
callback (and before non-daemon threads are joined), so objects registered here are closed
first, whether or not the user closed them.

Docs: docs/troubleshooting.md.
"""

from __future__ import annotations

import atexit
import threading
import weakref
from typing import Protocol

__all__ = ["Closable", "close_at_exit", "forget"]


class Closable(Protocol):
    """Anything with a ``close()`` that releases what it holds."""

    def close(self) -> None:
        """Release what the object holds; safe to call twice."""


_open: weakref.WeakSet = weakref.WeakSet()
_hook_registered = False


def _close_all() -> None:
    for obj in list(_open):
        try:
            obj.close()
        except Exception:  # at exit: best effort, nothing left to report to
            pass
    _open.clear()


def close_at_exit(obj: Closable) -> None:
    """Call ``obj.close()`` at interpreter exit unless it was ``forget``-ten first (``obj``
    is held weakly: registering never keeps it alive)."""
    global _hook_registered
    if not _hook_registered:
        register = getattr(threading, "_register_atexit", None)
        try:
            if register is None:
                raise RuntimeError("no threading exit hooks")
            register(_close_all)
        except RuntimeError:  # an interpreter without them, or one already shutting down
            atexit.register(_close_all)
        _hook_registered = True
    _open.add(obj)


def forget(obj: Closable) -> None:
    """``obj`` was closed: nothing to do for it at exit."""
    _open.discard(obj)
