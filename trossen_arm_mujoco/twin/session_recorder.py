"""What the clients of a served kit do, recorded as episodes of this project's schema.

One episode per client session (first ``configure`` to last ``cleanup``) or per
``episode_len`` frames: per frame the state at its start, the arms' commanded targets as the
16-value action, the task's reward after it and the cameras. The stepping thread only queues
the frame's state; a worker renders, spools (:mod:`.episode_spool`) and publishes each
episode atomically, so slow rendering delays the files, never the arms, and a spool that
could not be published is kept for the next ``serve --record``.

Docs: docs/cli/serve.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import os
import queue
import secrets
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import mujoco

from trossen_arm_mujoco.data.reader import episode_path
from trossen_arm_mujoco.data.schema import DEFAULT_COMPRESSION
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.twin.episode_spool import RECORDING_ID_ATTR, EpisodeSpool
from trossen_arm_mujoco.twin.frame import Frame
from trossen_arm_mujoco.twin.kit_world import KitWorld

__all__ = [
    "BACKLOG_WARN_S",
    "PROGRESS_S",
    "RENDER_NICENESS",
    "RecordOptions",
    "RecordStats",
    "SessionRecorder",
]

#: How much lower the recorder thread's priority is than the stepping thread's (nice steps).
RENDER_NICENESS: int = 10

#: A backlog of frames longer than this (s of simulated time) is reported once.
BACKLOG_WARN_S: float = 5.0
#: While :meth:`SessionRecorder.stop` waits for the worker, ``progress`` is called this often (s).
PROGRESS_S: float = 0.2


def _lower_priority() -> None:
    """Lower this thread's scheduling priority by :data:`RENDER_NICENESS` (Linux: a thread
    has its own nice value, and threads it starts, such as the software renderer's, inherit
    it); a no-op where that is not possible."""
    try:
        tid = threading.get_native_id()
        os.setpriority(os.PRIO_PROCESS, tid, os.getpriority(os.PRIO_PROCESS, tid) + RENDER_NICENESS)
    except (AttributeError, OSError):
        pass


@dataclass(frozen=True)
class RecordOptions:
    """Where and what to record.

    Attributes:
        folder: the dataset folder (exists; the caller holds its lock).
        camera_names, height, width: cameras rendered into every step (pixels).
        compression: image compression of the files (``data.schema.COMPRESSIONS``).
        episode_len: most frames per episode (None: one episode per session).
    """

    folder: Path
    camera_names: Sequence[str] = ()
    height: int = 480
    width: int = 640
    compression: str = DEFAULT_COMPRESSION
    episode_len: int | None = None


@dataclass
class _Episode:
    index: int
    seed: int
    attrs: dict[str, Any]  # set when it begins, never changed (the worker reads it)
    spool: EpisodeSpool | None = None
    reason: str = ""
    end_attrs: dict[str, Any] = field(default_factory=dict)  # set when it ends


@dataclass
class RecordStats:
    """Totals of a run: episodes written, frames rendered, rendering rate, failures, and
    the spools of episodes that could not be written (kept for the next run)."""

    written: list[Path] = field(default_factory=list)
    successes: int = 0
    frames: int = 0
    render_s: float = 0.0
    errors: list[str] = field(default_factory=list)
    kept: list[Path] = field(default_factory=list)  # spools kept for the next run

    @property
    def frames_per_s(self) -> float:
        """Frames rendered and spooled per second of worker time."""
        return self.frames / self.render_s if self.render_s > 0 else float("nan")


class SessionRecorder:
    """Records the sessions of ``world``'s clients; see the module doc.

    Args:
        world: the served world (its frame hooks are taken).
        options: where and what.
        first_index: index of the first episode (the world must be in that episode).
        say: prints one line (episode reports, warnings).
    """

    def __init__(
        self,
        world: KitWorld,
        options: RecordOptions,
        first_index: int,
        say: Callable[[str], None] = print,
    ) -> None:
        self.world, self.options, self.say = world, options, say
        self.index = int(first_index)
        self.stats = RecordStats()
        self._want = False  # a client session is open (set by the server threads)
        self._episode: _Episode | None = None  # being recorded (stepping thread)
        self._steps = 0
        self._queue: queue.Queue = queue.Queue()
        self._warned = False
        world.before_frame, world.on_frame = self._before_frame, self._on_frame
        self._worker = threading.Thread(target=self._work, name="kit-recorder", daemon=True)
        self._worker.start()

    # -- sessions (any thread) -----------------------------------------------------------
    def session_started(self) -> None:
        """A client connected while none was: record from the next frame."""
        self._want = True

    def session_ended(self) -> None:
        """The last client disconnected: end the episode at the next frame."""
        self._want = False

    # -- stepping thread (world lock held) ------------------------------------------------
    def _before_frame(self) -> None:
        if self._episode is None and self._want:
            self._begin()
        elif self._episode is not None and not self._want:
            self._end("session ended")
            self.world.reset(self.index)  # the next session starts from a fresh scene

    def _begin(self) -> None:
        w = self.world
        poses = w.object_poses()
        attrs: dict[str, Any] = {
            "task_name": w.task_name,
            "seed": int(w.seed),
            "base_seed": w.base_seed,
            "attempt": self.index,
            "dt": w.frame_dt,
            "source": "serve",
            "initial_env_state": w.env_state(),
            "object_names": list(poses),
            **({"box_pose": poses["box"]} if "box" in poses else {}),
            RECORDING_ID_ATTR: secrets.token_hex(8),
        }
        self._episode = _Episode(self.index, int(w.seed), attrs)
        self._steps = 0
        self._queue.put(("begin", self._episode))

    def _end(self, reason: str) -> None:
        assert self._episode is not None
        self._episode.reason = reason
        self._episode.end_attrs = {"realtime_factor": float(self.world.realtime_factor)}
        self._queue.put(("end", self._episode))
        self._episode = None
        self.index += 1

    def _on_frame(self, frame: Frame) -> None:
        if self._episode is None:
            return
        self._queue.put(("frame", frame))
        self._steps += 1
        backlog = self._queue.qsize() * self.world.frame_dt
        if backlog > BACKLOG_WARN_S and not self._warned:
            self._warned = True
            self.say(
                f"warning: rendering lags {backlog:.0f} s behind the arms; frames are "
                "queued and all written (smaller --image_size or fewer --cam_names keep "
                "up)"
            )
        if self.options.episode_len is not None and self._steps >= self.options.episode_len:
            self._end(f"{self._steps} steps (--episode_len)")
            self.world.reset(self.index, keep_arms=True)  # next objects, arms untouched

    # -- worker thread ----------------------------------------------------------------------
    def _work(self) -> None:
        _lower_priority()  # the arms' stepping thread comes first; the GL threads inherit it
        o = self.options
        cameras, rdata = None, None
        if o.camera_names:
            from trossen_arm_mujoco.sim.cameras import CameraSet

            cameras = CameraSet(self.world.model, o.camera_names, o.height, o.width)
            rdata = mujoco.MjData(self.world.model)
        episode: _Episode | None = None
        try:
            while True:
                kind, item = self._queue.get()
                if kind == "stop":
                    return
                try:
                    if kind == "begin":
                        episode = item
                        episode.spool = self._spool(episode)
                    elif kind == "frame" and episode is not None and episode.spool is not None:
                        start = time.perf_counter()
                        images = self._render(cameras, rdata, item)
                        episode.spool.append(item, images)
                        self.stats.frames += 1
                        self.stats.render_s += time.perf_counter() - start
                    elif kind == "end" and episode is not None:
                        self._publish(episode)
                        episode = None
                except Exception as exc:  # a failed write: say so, keep serving
                    self._fail(episode, exc)
                    episode = None
        finally:
            if episode is not None:  # the worker ends early: keep what it has
                self._keep(episode, "the recorder stopped before the episode ended")
            if cameras is not None:
                cameras.close()

    def _spool(self, episode: _Episode) -> EpisodeSpool:
        """A named spool holding what a later run needs to publish it (:mod:`.episode_spool`)."""
        o = self.options
        meta = {
            "index": episode.index,
            "attrs": episode.attrs,
            "compression": o.compression,
            "task_max_reward": self._top,
        }
        return EpisodeSpool(o.folder, o.camera_names, o.height, o.width, meta=meta)

    @property
    def _top(self) -> float:
        return float(getattr(self.world.task, "max_reward", 1.0))

    def _render(self, cameras, rdata, frame: Frame) -> dict:
        if cameras is None:
            return {}
        rdata.qpos[:] = frame.qpos_full
        rdata.mocap_pos[:], rdata.mocap_quat[:] = frame.mocap_pos, frame.mocap_quat
        mujoco.mj_forward(self.world.model, rdata)
        return cameras.render_all(rdata)

    def _publish(self, episode: _Episode) -> None:
        spool = episode.spool
        assert spool is not None
        n = len(spool)
        if n == 0:
            spool.discard()
            return
        rewards = spool.rewards
        final, best = float(rewards[-1]), float(rewards.max())
        top = self._top
        success = final >= top
        attrs = {
            **episode.attrs,
            **episode.end_attrs,
            "success": success,
            "final_reward": final,
            "max_reward": best,
            "end_reason": episode.reason,
        }
        path = spool.publish(
            episode_path(self.options.folder, episode.index), attrs, self.options.compression
        )
        self.stats.written.append(path)
        self.stats.successes += int(success)
        dt = self.world.frame_dt
        self.say(
            f"{path.name}: {n} steps ({n * dt:.2f} s), {episode.reason}; reward final "
            f"{final:g}, max {best:g} of {top:g}: {'success' if success else 'no success'}"
        )

    def _fail(self, episode: _Episode | None, exc: Exception) -> None:
        text = str(exc) if isinstance(exc, (UserError, OSError)) else repr(exc)
        if episode is None:
            line = f"an episode was not written: {' '.join(text.split())}"
            self.stats.errors.append(line)
            self.say(f"error: {line}")
            return
        self._keep(episode, " ".join(text.split()))

    def _keep(self, episode: _Episode, why: str) -> None:
        """``episode`` cannot be published now: keep its spool (closed) when it holds steps
        and say where, else delete it; counted as an error."""
        spool = episode.spool
        name = f"episode_{episode.index}.hdf5"
        line = f"{name} was not written: {why}"
        if spool is not None and len(spool) and spool.path is not None:
            spool.close()
            self.stats.kept.append(spool.path)
            line += (
                f"; its {len(spool)} steps are kept in {spool.path}: the next serve "
                "--record into this folder publishes them"
            )
        elif spool is not None:
            spool.discard()
        episode.spool = None
        self.stats.errors.append(line)
        self.say(f"error: {line}")

    # -- end --------------------------------------------------------------------------------
    @property
    def backlog(self) -> int:
        """Frames (and session events) queued for the worker."""
        return self._queue.qsize()

    def stop(self, progress: Callable[[], None] | None = None) -> RecordStats:
        """End the episode being recorded (call after the world stopped stepping), write
        everything queued, end the worker; returns the run's totals. It waits for the worker
        however long the queue takes (the recording is never cut short), calling
        ``progress`` every :data:`PROGRESS_S` meanwhile (e.g. to report signals);
        idempotent."""
        if self._episode is not None:
            self._end("serve stopped")
        if self._worker.is_alive():
            self._queue.put(("stop", None))
        while self._worker.is_alive():
            self._worker.join(PROGRESS_S)
            if progress is not None and self._worker.is_alive():
                progress()
        self.world.before_frame = self.world.on_frame = None
        return self.stats
