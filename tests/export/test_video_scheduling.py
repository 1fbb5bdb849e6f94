"""Encoding a LeRobot video leaves the calling thread's scheduling as it was: SVT-AV1, run
as root, switches the thread that feeds it to real-time scheduling (SCHED_FIFO 99), which
would then starve the rest of the machine for the life of the process."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

from trossen_arm_mujoco.export.lerobot_format import VIDEO_PATH
from trossen_arm_mujoco.export.lerobot_video import CameraVideo, VideoSettings, kept_scheduling

pytest.importorskip("av")
linux = pytest.mark.skipif(not hasattr(os, "sched_getscheduler"), reason="Linux scheduling")


def _encode(root, codec: str) -> None:
    video = CameraVideo(
        root,
        "observation.images.cam_high",
        VIDEO_PATH,
        VideoSettings(codec=codec),
        fps=30,
        height=32,
        width=32,
        max_file_mb=100,
        chunks_size=1000,
    )
    video.begin_episode()
    video.write(np.zeros((4, 32, 32, 3), dtype=np.uint8))
    video.end_episode()
    video.close()


@linux
@pytest.mark.parametrize("codec", ["libsvtav1", "h264"])
def test_encoding_keeps_the_threads_scheduling(tmp_path, codec):
    seen = {}

    def run():  # a thread of its own: the test process keeps its scheduling whatever happens
        before = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
        _encode(tmp_path, codec)
        seen["before"] = before
        seen["after"] = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)

    worker = threading.Thread(target=run)
    worker.start()
    worker.join(60)
    assert seen["after"] == seen["before"] == (os.SCHED_OTHER, 0)
    assert list(tmp_path.rglob("*.mp4"))


@linux
@pytest.mark.skipif(os.geteuid() != 0, reason="only root may switch a thread to SCHED_FIFO")
def test_kept_scheduling_undoes_a_switch_to_real_time():
    seen = {}

    def run():
        with kept_scheduling():
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
            seen["inside"] = os.sched_getscheduler(0)
        seen["after"] = os.sched_getscheduler(0)

    worker = threading.Thread(target=run)
    worker.start()
    worker.join(10)
    assert seen == {"inside": os.SCHED_FIFO, "after": os.SCHED_OTHER}
