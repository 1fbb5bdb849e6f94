"""Episodes on the served kit: a small loopback control channel (JSON lines over TCP).

``serve --control_port P`` listens on ``127.0.0.1:P`` (``--control_host``, in 127.0.0.0/8
only). A client sends one JSON object per line (``{"cmd": "start", "seed": 7}`` with optional
``episode``, ``object_poses`` (m, quat wxyz, world), ``randomization`` and ``goal`` (m,
world); ``{"cmd": "end"}``; ``{"cmd": "status"}``) and gets one back, ``{"ok": true, ...}``
or ``{"ok": false, "error": "..."}``. ``start`` resets the world to the episode's scene;
replies carry the episode's reward, success and stage times. Oversized, too deeply nested or
invalid requests are refused with one line, and the channel serves the next.

Docs: docs/rehearsal.md (Episodes: the control channel); the full protocol:
docs/concepts/design-notes.md.
"""

from __future__ import annotations

import json
import logging
import queue
import socket
import threading
from collections.abc import Callable
from typing import Any, BinaryIO

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.gym.inputs import object_pose
from trossen_arm_mujoco.twin.frame import Frame
from trossen_arm_mujoco.twin.kit_world import KitWorld
from trossen_arm_mujoco.twin.serving import LISTEN_BACKLOG, Acceptor, check_loopback, shut

__all__ = [
    "MAX_DEPTH",
    "MAX_LINE",
    "MAX_SEED",
    "EpisodeControl",
    "EpisodeTracker",
    "nesting_depth",
    "read_request",
    "skip_line",
]

log = logging.getLogger(__name__)

#: Largest run seed (as ``record``).
MAX_SEED = 2**63 - 1
#: Seconds a request waits for the stepping thread to apply it.
APPLY_TIMEOUT_S = 10.0
#: Longest request line accepted (bytes, newline included); a longer one is refused
#: without being held whole.
MAX_LINE = 1 << 16
#: Deepest nesting of arrays and objects a request may have (a start request needs 3).
MAX_DEPTH = 16


class EpisodeTracker:
    """The score of the running episode, fed every frame (stepping thread, lock held)."""

    def __init__(self, world: KitWorld) -> None:
        self.world = world
        self.running = False
        self._reset_counts()

    def _reset_counts(self) -> None:
        self.frames, self.sum_reward, self.max_reward, self.reward = 0, 0.0, 0.0, 0.0
        self.success, self.start_time, self.stages = False, float(self.world.data.time), {}

    def begin(self) -> None:
        """Start counting an episode from the world's current state."""
        self._reset_counts()
        self.reward = float(self.world.task.get_reward())
        # the best so far is the start's (a single arm's shaped reward is negative until its
        # goal is near; a kit task's starts at 0)
        self.max_reward = self.reward
        self.running = True

    def on_frame(self, frame: Frame) -> None:
        """Add one world frame (its reward and success) to the running episode's totals
        and first stage times; ignored when no episode runs."""
        if not self.running:
            return
        r = float(frame.reward)
        self.frames += 1
        self.reward, self.sum_reward = r, self.sum_reward + r
        self.max_reward = max(self.max_reward, r)
        self.success = self.success or bool(frame.success)
        t = float(self.world.data.time) - self.start_time
        for level in range(1, int(np.floor(r)) + 1):
            self.stages.setdefault(str(level), round(t, 4))

    def report(self) -> dict[str, Any]:
        """The reply fields (see the module doc)."""
        w = self.world
        poses = w.object_poses()
        return {
            "task": w.task_name,
            "episode": w.episode_index,
            "seed": w.base_seed,
            "running": self.running,
            "frames": self.frames,
            "sim_time": round(float(w.data.time) - self.start_time, 6),
            "reward": self.reward,
            "max_reward": self.max_reward,
            "sum_reward": self.sum_reward,
            "task_max_reward": float(getattr(w.task, "max_reward", 1.0)),
            "success": self.success,
            "stages": dict(self.stages),
            "object_names": list(poses),
            "env_state": w.env_state().tolist(),
            **_goal_field(w.task),
            **({} if w.scene_randomization is None else {"randomization": w.scene_randomization}),
        }


class EpisodeControl:
    """The control channel of ``world``; see the module doc.

    Args:
        world: the served world (its ``frame_listeners`` get the tracker).
        port: TCP port on ``host``; one in use is a one-line ``UserError``.
        host: address in 127.0.0.0/8.
        recorder: a ``SessionRecorder`` whose episodes follow start / end (optional).
        say: one line per episode start and end (optional).
    """

    def __init__(
        self,
        world: KitWorld,
        port: int,
        host: str = "127.0.0.1",
        recorder: Any = None,
        say: Callable[[str], None] | None = None,
    ) -> None:
        self.host = check_loopback(host, "--control_host")
        if not 1 <= int(port) <= 65535:
            raise UserError(f"--control_port must be in 1..65535, got {port}")
        self.world, self.port, self.recorder, self.say = world, int(port), recorder, say
        self.tracker = EpisodeTracker(world)
        self._requests: queue.Queue = queue.Queue()
        self._listen = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listen.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listen.bind((self.host, self.port))
        except OSError as exc:
            self._listen.close()
            raise UserError(
                f"cannot serve the control channel on {self.host}:{self.port} "
                f"({exc.strerror}); choose another --control_port"
            ) from None
        self._listen.listen(LISTEN_BACKLOG)  # a burst of clients waits to be accepted
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._clients: list[socket.socket] = []
        self._lock = threading.Lock()  # the two lists above: the accept thread and stop()
        world.frame_listeners.append(self._on_frame)

    def start(self) -> EpisodeControl:
        """Accept clients in a daemon thread until :meth:`stop`."""
        t = threading.Thread(target=self._accept, name="kit-control", daemon=True)
        t.start()
        self._threads.append(t)
        return self

    # -- stepping thread (lock held) ------------------------------------------------------
    def _on_frame(self, frame: Frame) -> None:
        self.tracker.on_frame(frame)
        try:
            request, done = self._requests.get_nowait()  # one per frame
        except queue.Empty:
            return
        try:
            done.append(self._apply(request))
        except UserError as exc:
            done.append({"ok": False, "error": str(exc)})
        except Exception as exc:  # a bad request must not stop the world
            done.append({"ok": False, "error": f"{type(exc).__name__}: {exc}"})

    def _apply(self, request: dict[str, Any]) -> dict[str, Any]:
        cmd = request["cmd"]
        if cmd == "start":
            seed, episode, poses = _start_args(request, self.world)
            record = request.get("randomization")
            if record is not None and not isinstance(record, dict):
                raise UserError(
                    "start: randomization must be a record (an object) as the "
                    "start reply's 'randomization' gives it"
                )
            goal = _start_goal(request, self.world)
            self.world.base_seed = seed
            self.world.reset(episode, object_poses=poses, randomization=record)
            if goal is not None:  # the client's goal, shown by the task's marker
                self.world.task.goal = goal
                self.world.task.initialize_episode()
            self.tracker.begin()
            if self.recorder is not None:
                self.recorder.session_started()
            if self.say is not None:
                self.say(
                    f"episode started: seed {seed}, episode {episode}"
                    + (" (objects placed by the client)" if poses else "")
                )
        elif cmd == "end":
            if not self.tracker.running:
                raise UserError("no episode is running: send start first")
            self.tracker.running = False
            if self.recorder is not None:
                self.recorder.session_ended()
            if self.say is not None:
                t = self.tracker
                self.say(
                    f"episode ended: max reward {t.max_reward:g}, "
                    f"{'success' if t.success else 'no success'}"
                )
        return {"ok": True, **self.tracker.report()}

    # -- server threads -------------------------------------------------------------------
    def _accept(self) -> None:
        """Accept clients, one thread each, until stopped; a connection refused for want of
        file descriptors (or a thread) is logged once and the channel serves on."""
        acceptor = Acceptor(self._listen, "control channel", log, self._stop.wait)
        try:
            while not self._stop.is_set():
                try:
                    conn = acceptor.accept()
                except OSError:
                    return  # shut by stop()
                if conn is not None:
                    self._start_client(conn)
        finally:
            acceptor.close()

    def _start_client(self, conn: socket.socket) -> None:
        t = threading.Thread(
            target=self._serve, args=(conn,), name="kit-control-client", daemon=True
        )
        with self._lock:
            self._threads = [c for c in self._threads if c.is_alive()]  # the clients gone
            self._clients.append(conn)
            try:
                t.start()
            except RuntimeError as exc:  # no thread can be started now: refuse this client
                self._clients.remove(conn)
                shut(conn)
                log.warning("control channel: cannot serve a client (%s): refused it", exc)
                return
            self._threads.append(t)

    def _serve(self, conn: socket.socket) -> None:
        try:
            self._serve_lines(conn)
        finally:
            with self._lock:
                if conn in self._clients:
                    self._clients.remove(conn)

    def _serve_lines(self, conn: socket.socket) -> None:
        reader = conn.makefile("rb")
        try:
            while (got := read_request(reader)) is not None:
                line, too_long = got
                if too_long:  # refused at once; the rest of the line is then dropped
                    reply = {
                        "ok": False,
                        "error": f"request line longer than {MAX_LINE} bytes: "
                        "refused (one JSON object per line)",
                    }
                else:
                    reply = self.handle(line)
                conn.sendall((json.dumps(reply) + "\n").encode())
                if too_long:
                    skip_line(reader)
        except OSError:
            pass
        finally:
            reader.close()
            shut(conn)

    def handle(self, line: bytes | str) -> dict[str, Any]:
        """One request line -> its reply (``status`` at once; ``start`` and ``end`` applied
        by the stepping thread between two frames)."""
        raw = line.encode() if isinstance(line, str) else line
        if nesting_depth(raw, MAX_DEPTH) > MAX_DEPTH:
            return {"ok": False, "error": f"request nested deeper than {MAX_DEPTH} levels: refused"}
        try:
            request = json.loads(raw)
        except (ValueError, RecursionError) as exc:
            return {"ok": False, "error": f"not a JSON line: {exc}"}
        if not isinstance(request, dict) or request.get("cmd") not in ("start", "end", "status"):
            return {"ok": False, "error": 'expected {"cmd": "start" | "end" | "status", ...}'}
        if request["cmd"] == "status":
            with self.world.lock:
                return {"ok": True, **self.tracker.report()}
        done: list[dict[str, Any]] = []
        self._requests.put((request, done))
        waited = 0.0
        while not done and waited < APPLY_TIMEOUT_S and not self._stop.is_set():
            self._stop.wait(0.002)
            waited += 0.002
        return done[0] if done else {"ok": False, "error": "the world is not stepping"}

    def stop(self) -> None:
        """Close the channel and its clients (idempotent)."""
        self._stop.set()
        shut(self._listen)
        with self._lock:
            clients, threads = list(self._clients), list(self._threads)
        for conn in clients:
            shut(conn)
        for t in threads:
            t.join(2.0)
        if self._on_frame in self.world.frame_listeners:
            self.world.frame_listeners.remove(self._on_frame)


def _goal_field(task: Any) -> dict[str, Any]:
    """``{"goal": [x, y, z]}`` of a goal-conditioned task (m, world); empty otherwise."""
    if not getattr(task, "goal_conditioned", False):
        return {}
    return {"goal": np.asarray(task.goal, dtype=float).tolist()}


def _start_goal(request: dict[str, Any], world: KitWorld) -> np.ndarray | None:
    """``start``'s ``goal``, checked: 3 finite numbers (m) in the task's workspace, for a
    goal-conditioned task only (``UserError`` otherwise); None when not sent."""
    raw = request.get("goal")
    if raw is None:
        return None
    task = world.task
    if not getattr(task, "goal_conditioned", False):
        raise UserError(f"start: task '{world.task_name}' has no goal")
    try:
        goal = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        goal = np.zeros(0)
    if goal.shape != (3,) or not np.isfinite(goal).all():
        raise UserError(f"start: goal must be 3 finite numbers [x, y, z] (m), got {raw!r:.60}")
    if hasattr(task, "ws_low") and not (
        np.all(goal >= task.ws_low) and np.all(goal <= task.ws_high)
    ):
        raise UserError(f"start: goal {goal.tolist()} is outside the task's workspace")
    return goal


def _start_args(request: dict[str, Any], world: KitWorld) -> tuple[int, int, dict | None]:
    """``start``'s seed, episode and object poses, checked (``UserError`` otherwise)."""
    seed, episode = request.get("seed", world.base_seed), request.get("episode", 0)
    for name, value, top in (("seed", seed, MAX_SEED), ("episode", episode, 10**9)):
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= top:
            raise UserError(f"start: {name} must be an int in 0..{top}, got {value!r}")
    raw = request.get("object_poses")
    if raw is None:
        return seed, episode, None
    names = list(world.object_poses())
    if not isinstance(raw, dict):
        raise UserError("start: object_poses must be {name: [x, y, z, qw, qx, qy, qz]}")
    task = world.task
    workspace = (task.ws_low, task.ws_high) if hasattr(task, "ws_low") else None
    poses = {}
    for name, pose in raw.items():
        if name not in names:
            raise UserError(f"start: unknown object '{name}'; objects: {', '.join(names)}")
        poses[name] = object_pose(pose, f"start: the pose of '{name}'", workspace)
    return seed, episode, poses


def nesting_depth(line: bytes, stop: int) -> int:
    """How deep the JSON arrays and objects of ``line`` nest (brackets inside strings not
    counted), or ``stop`` + 1 as soon as it is deeper than ``stop``: checked before parsing,
    so that no request can make the parser recurse past Python's limit."""
    depth = deepest = 0
    in_string = escaped = False
    for byte in line:
        if in_string:
            if escaped:
                escaped = False
            elif byte == 0x5C:  # backslash
                escaped = True
            elif byte == 0x22:  # closing quote
                in_string = False
        elif byte == 0x22:
            in_string = True
        elif byte in (0x5B, 0x7B):  # [ {
            depth += 1
            if depth > stop:
                return stop + 1
            deepest = max(deepest, depth)
        elif byte in (0x5D, 0x7D):  # ] }
            depth -= 1
    return deepest


def read_request(reader: BinaryIO, limit: int = MAX_LINE) -> tuple[bytes, bool] | None:
    """The next request line of ``reader`` and whether it is too long (None at the end of
    the stream). At most ``limit`` bytes of a line (its newline included) are read: of a
    longer one, the first ``limit`` bytes come back with True (:func:`skip_line` drops the
    rest)."""
    line = reader.readline(limit)
    if not line:
        return None
    # whole, or the stream's unended last line
    return line, not (line.endswith(b"\n") or len(line) < limit)


def skip_line(reader: BinaryIO, chunk: int = MAX_LINE) -> None:
    """Read on to the end of the current line (its newline) or of the stream, ``chunk``
    bytes at a time, keeping none of it."""
    while (rest := reader.readline(chunk)) and not rest.endswith(b"\n"):
        pass
