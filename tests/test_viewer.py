"""The live viewer, headless: the no-display paths, the start timeout, thumbnails, closing.

No window is opened: ``mujoco.viewer.launch_passive`` and the viewer handle are faked.
"""

from __future__ import annotations

import sys
import threading
import time

import mujoco
import mujoco.viewer
import numpy as np
import pytest

from trossen_arm_mujoco import viewer
from trossen_arm_mujoco.viewer import LiveViewer, close_viewer, display_problem, launch_viewer


class FakeHandle:
    """What LiveViewer uses of mujoco's passive viewer handle."""

    def __init__(self, running: bool = True, overlays: bool = True):
        self.running = running
        self.overlays = overlays
        self.syncs = 0
        self.images: list = []
        self.closed = False

    def is_running(self) -> bool:
        return self.running

    def sync(self) -> None:
        self.syncs += 1

    def set_images(self, rects) -> None:
        if not self.overlays:
            raise AttributeError("no overlays in this viewer")
        self.images = rects

    def close(self) -> None:
        self.closed = True


def test_no_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    assert display_problem() == "no DISPLAY"
    assert display_problem(probe_window=False) == "no DISPLAY"


def test_glfw_missing(monkeypatch):
    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setitem(sys.modules, "glfw", None)  # import glfw -> ImportError
    problem = display_problem()
    assert problem is not None and problem.startswith("GLFW unavailable")


def test_open_without_display_says_why_once_and_returns_none(monkeypatch, capsys):
    monkeypatch.delenv("DISPLAY", raising=False)

    def must_not_launch(*args, **kwargs):
        raise AssertionError("launch_viewer called without a display")

    monkeypatch.setattr(viewer, "launch_viewer", must_not_launch)
    assert LiveViewer.open(None, None) is None
    assert capsys.readouterr().err == "live view off: no DISPLAY; continuing headless\n"


def test_open_reports_a_failed_launch(monkeypatch, capsys):
    monkeypatch.setattr(viewer, "display_problem", lambda probe_window=True: None)

    def failing(model, data, timeout=None):
        raise RuntimeError("viewer failed to start: GLX error")

    monkeypatch.setattr(viewer, "launch_viewer", failing)
    assert LiveViewer.open(None, None) is None
    err = capsys.readouterr().err
    assert err == "live view off: viewer failed to start: GLX error; continuing headless\n"


def test_open_launches_in_this_thread(monkeypatch):
    handle = FakeHandle()
    calls = []

    def launch(model, data, timeout=1.0):
        calls.append(timeout)
        return handle, []

    monkeypatch.setattr(viewer, "display_problem", lambda probe_window=True: None)
    monkeypatch.setattr(viewer, "launch_viewer", launch)
    live = LiveViewer.open("model", "data")
    assert isinstance(live, LiveViewer) and live.handle is handle
    assert calls == [None]  # no helper thread: its GLX context would clash with offscreen


def test_launch_gives_up_after_the_timeout(monkeypatch):
    release = threading.Event()
    monkeypatch.setattr(mujoco.viewer, "launch_passive", lambda *a, **k: release.wait(5))
    start = time.monotonic()
    try:
        with pytest.raises(RuntimeError, match=r"did not open within 0\.2 s"):
            launch_viewer(None, None, timeout=0.2)
    finally:
        release.set()
    assert time.monotonic() - start < 2.0


def test_launch_reports_the_viewer_error(monkeypatch):
    def broken(*args, **kwargs):
        raise OSError("no GLX")

    monkeypatch.setattr(mujoco.viewer, "launch_passive", broken)
    with pytest.raises(RuntimeError, match="viewer failed to start: no GLX"):
        launch_viewer(None, None, timeout=2.0)


def test_launch_returns_the_threads_the_viewer_started(monkeypatch):
    handle, stop = FakeHandle(), threading.Event()

    def launch(model, data, show_left_ui, show_right_ui):
        assert (show_left_ui, show_right_ui) == (False, False)
        threading.Thread(target=stop.wait, name="fake-render", daemon=True).start()
        return handle

    monkeypatch.setattr(mujoco.viewer, "launch_passive", launch)
    try:
        for timeout in (None, 2.0):
            got, threads = launch_viewer(None, None, timeout=timeout)
            assert got is handle
            assert [t.name for t in threads] == ["fake-render"]
    finally:
        stop.set()


def test_close_viewer_closes_and_joins():
    handle, done = FakeHandle(), []
    worker = threading.Thread(target=lambda: (time.sleep(0.05), done.append(1)))
    worker.start()
    close_viewer(handle, [worker], timeout=5.0)
    assert handle.closed and done == [1] and not worker.is_alive()


def test_update_shows_strided_thumbnails_side_by_side():
    handle = FakeHandle()
    live = LiveViewer(handle, [], thumb_stride=4)
    images = {"a": np.zeros((40, 64, 3), np.uint8), "b": np.ones((20, 32, 3), np.uint8)}
    assert live.update(images) is True and handle.syncs == 1
    (rect_a, thumb_a), (rect_b, thumb_b) = handle.images
    assert thumb_a.shape == (10, 16, 3) and thumb_b.shape == (5, 8, 3)
    assert thumb_a.flags["C_CONTIGUOUS"] and thumb_b.flags["C_CONTIGUOUS"]
    assert (rect_a.left, rect_a.bottom, rect_a.width, rect_a.height) == (0, 0, 16, 10)
    assert (rect_b.left, rect_b.width, rect_b.height) == (16 + 4, 8, 5)


def test_update_without_images_or_overlays_still_redraws():
    handle = FakeHandle(overlays=False)
    live = LiveViewer(handle, [])
    assert live.update() is True
    assert live.update({"a": np.zeros((8, 8, 3), np.uint8)}) is True  # 3D view only
    assert handle.syncs == 2 and handle.images == []


def test_update_after_the_window_closed():
    handle = FakeHandle(running=False)
    live = LiveViewer(handle, [])
    assert live.update({"a": np.zeros((8, 8, 3), np.uint8)}) is False
    assert handle.syncs == 0 and not live.is_running()


def test_close_never_raises(monkeypatch):
    live = LiveViewer(FakeHandle(), [])

    def broken(handle, threads, timeout=10.0):
        raise RuntimeError("Xlib went away")

    monkeypatch.setattr(viewer, "close_viewer", broken)
    live.close()
