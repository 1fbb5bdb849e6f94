"""The served kit's world: both arms and the task's objects, stepping in real time in a thread.

One :class:`KitWorld` holds the joint flavour of a registered Stationary AI task; episode
``k`` of a world made with ``base_seed=S`` is the scene ``record --seed S`` records as its
episode ``k``. Every control tick (``ctrl_dt``, the 2 ms physics step) each arm's
:class:`ArmState` (6 joints rad, the gripper carriage m) goes to the robot layer and physics
steps once; a frame (``frame_dt``, default the task's ``policy_dt``) is what a recorder sees
(:class:`Frame`). :meth:`start` steps in a paced thread, :meth:`advance` without pacing; all
access to model and data goes through :attr:`lock`.

Docs: docs/cli/serve.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Mapping
from typing import Any

import mujoco
import numpy as np

from trossen_arm_mujoco.collect.pipeline import episode_seed
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.names import lookup_id
from trossen_arm_mujoco.real.controller_checks import EFFORT, EXTERNAL_EFFORT, IDLE, Fault
from trossen_arm_mujoco.robot.layout import ARM_JOINTS, SIDES, VENDOR16_LAYOUT
from trossen_arm_mujoco.sim.looks import SceneLooks, checked_looks
from trossen_arm_mujoco.sim.scene import whole_ratio
from trossen_arm_mujoco.tasks import registry
from trossen_arm_mujoco.tasks.randomization_schema import RANDOMIZATION_KEY
from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings
from trossen_arm_mujoco.twin.commands import ArmState
from trossen_arm_mujoco.twin.faults import lag_fault_of
from trossen_arm_mujoco.twin.frame import Frame
from trossen_arm_mujoco.twin.pacer import Pacer

__all__ = ["COUPLED_FINGER", "DRIVER_JOINTS", "GROUPS", "KitWorld"]

#: MJCF joints of the 7 driver values of one arm (unprefixed), and the coupled finger.
DRIVER_JOINTS: tuple[str, ...] = (*ARM_JOINTS, "left_carriage_joint")
COUPLED_FINGER = "right_carriage_joint"

#: Move groups commanded every tick, in the order of the 14-value target vector.
GROUPS: tuple[str, ...] = ("left_arm", "left_gripper", "right_arm", "right_gripper")


class KitWorld:
    """Both arms of the kit and a task's objects; see the module doc. (``twin.arm_world.
    ArmWorld`` is the single arm's world, with the arm ``sides = ("follower",)``.)

    Args:
        task_name: a registered kit task (``tasks.registry.kit_names``).
        base_seed: run seed: episode ``k`` uses ``episode_seed(base_seed, k)``.
        episode_index: the episode the world starts in.
        fps: frames per second of simulated time (the recording rate); default the task's.
        object_poses: object name -> pose [xyz, quat wxyz] placed instead of the sampled
            ones in the first episode (a replay starting from a recorded scene).
        looks: how the served cameras and the recorder draw the scene (shadows,
            antialiasing; ``sim.looks.SceneLooks``); default ``SceneLooks()``.
        randomize: each episode's scene randomized as the task's ``randomization`` section
            says, from the episode's seed (``serve --randomize``); default the nominal scene.
        randomization: a ``randomization`` section replacing the task's, kind by kind
            (``serve --randomization FILE``); implies ``randomize``.
    """

    #: The arms, in the order of their values (7 each).
    sides: tuple[str, ...] = SIDES
    #: Move groups commanded every tick, in the order of the target vector.
    groups: tuple[str, ...] = GROUPS

    def check_task(self, entry: registry.TaskEntry) -> None:
        """A one-line ``UserError`` unless ``entry`` is a task this world holds."""
        if entry.name not in registry.kit_names():
            raise UserError(
                f"task '{entry.name}' is not a Stationary AI (two-arm) task; a served kit "
                f"holds one of: {', '.join(registry.kit_names())}"
            )

    def mjcf_name(self, side: str, name: str) -> str:
        """The model's name of arm ``side``'s joint or actuator ``name``."""
        return f"{side}/{name}"

    def __init__(
        self,
        task_name: str = registry.DEFAULT_TASK,
        base_seed: int = 0,
        episode_index: int = 0,
        fps: float | None = None,
        object_poses: Mapping[str, np.ndarray] | None = None,
        looks: SceneLooks | None = None,
        randomize: bool = False,
        randomization: Mapping[str, Any] | None = None,
    ) -> None:
        entry = registry.load(task_name)
        self.check_task(entry)
        config = entry.load_config()
        ctrl_dt = float(config.get("sim_dt") or 0.002)
        frame_dt = float(config["policy_dt"]) if fps is None else 1.0 / float(fps)
        if fps is not None and not (np.isfinite(fps) and 0 < fps <= 1.0 / ctrl_dt):
            raise UserError(f"--fps must be in (0, {1.0 / ctrl_dt:g}], got {fps:g}")
        try:
            self.ticks_per_frame = whole_ratio(frame_dt, ctrl_dt, "1/fps", "the physics step")
        except UserError as exc:
            valid = ", ".join(f"{1.0 / (ctrl_dt * n):g}" for n in (2, 4, 5, 10, 20, 25))
            raise UserError(f"{exc}; e.g. --fps {valid}") from None
        self.task_name, self.base_seed = entry.name, int(base_seed)
        self.frame_dt, self.ctrl_dt = self.ticks_per_frame * ctrl_dt, ctrl_dt
        self.randomize = bool(randomize) or randomization is not None
        settings = SamplerSettings(looks=checked_looks(looks), randomize=self.randomize)
        section = {} if randomization is None else {RANDOMIZATION_KEY: dict(randomization)}
        self.sampler = registry.make_sampler(
            entry.name, settings, ctrl_dt=ctrl_dt, policy_dt=frame_dt, **section
        )
        self.scene = self.sampler.scene
        self.model, self.data = self.scene.model, self.scene.data
        self.robot = self.scene.robots[self.sampler.robot_name]
        self.lock = threading.RLock()
        self._index_joints()
        self.task = None
        self.episode_index, self.seed = int(episode_index), 0
        self.reset(self.episode_index, object_poses=object_poses)
        self.arms = {side: ArmState(self.measured(side)) for side in self.sides}
        #: Hooks of a recorder, called in the stepping thread with the lock held: before
        #: each frame, and with each finished frame.
        self.before_frame: Callable[[], None] | None = None
        self.on_frame: Callable[[Frame], None] | None = None
        #: More hooks called with each finished frame after ``on_frame`` (stepping thread,
        #: lock held): e.g. the episode control channel's score (``episode_control``).
        self.frame_listeners: list[Callable[[Frame], None]] = []
        #: Called (stepping thread, lock held) with ``(side, Fault)`` when an arm's target
        #: runs too far ahead of its setpoint (``faults.lag_fault``, checked while the world
        #: keeps real time: ``pacer.on_time``); the arm is idled.
        self.on_fault: Callable[[str, Fault], None] | None = None
        self.frames = 0
        #: Paces the thread (``start``) to wall-clock time, one control tick at a time.
        self.pacer = Pacer(self.ctrl_dt)
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    def layout_joints(self) -> list[str]:
        """The model's joints of the recorded ``qpos`` / ``qvel`` values, in order (the
        kit: the 16-value layout)."""
        values = (*ARM_JOINTS, COUPLED_FINGER, "left_carriage_joint")
        return [self.mjcf_name(s, j) for s in self.sides for j in values]

    def _index_joints(self) -> None:
        m, name, sides = self.model, self.mjcf_name, self.sides
        jid = {s: [lookup_id(m, "joint", name(s, j)) for j in DRIVER_JOINTS] for s in sides}
        self.qadr = {s: m.jnt_qposadr[jid[s]].copy() for s in sides}
        self.dadr = {s: m.jnt_dofadr[jid[s]].copy() for s in sides}
        twin = {s: lookup_id(m, "joint", name(s, COUPLED_FINGER)) for s in sides}
        self.twin_dadr = {s: int(m.jnt_dofadr[twin[s]]) for s in sides}
        ids = [lookup_id(m, "joint", n) for n in self.layout_joints()]
        self.layout_qadr, self.layout_dadr = m.jnt_qposadr[ids].copy(), m.jnt_dofadr[ids].copy()
        acts = {s: [*(name(s, j) for j in ARM_JOINTS), name(s, "gripper")] for s in sides}
        self.act = {s: np.array([lookup_id(m, "actuator", a) for a in acts[s]]) for s in sides}
        self._batch = self.robot.joint_target_batch(self.groups)

    # -- episodes -------------------------------------------------------------------------
    def reset(
        self,
        episode_index: int,
        keep_arms: bool = False,
        object_poses: Mapping[str, np.ndarray] | None = None,
        randomization: Mapping[str, Any] | None = None,
    ) -> None:
        """Start episode ``episode_index``: the scene of ``record``'s episode of that index.

        ``keep_arms``: only the objects move to the new episode's poses; the arms keep their
        state and targets (a new episode while clients are connected). ``randomization``: a
        record (``tasks.randomization``) applied to the scene instead of drawing one (a
        client's scene, e.g. ``eval --backend wire --randomize``'s).

        Args:
            episode_index: the index of ``record``'s episode whose scene it is.
            keep_arms: only the objects move to the new episode's poses; the arms keep their state
                and targets.
            object_poses: object name -> pose (7,) [x, y, z, qw, qx, qy, qz] (m, world) placed
                instead of the sampled ones.
            randomization: a ``tasks.randomization`` record applied to the scene instead of drawing
                one.
        """
        with self.lock:
            saved = None
            if keep_arms:
                d = self.data
                saved = (
                    d.qpos[self.layout_qadr].copy(),
                    d.qvel[self.layout_dadr].copy(),
                    d.ctrl.copy(),
                )
            seed = episode_seed(self.base_seed, episode_index)
            self.task = self.sampler.next_task(
                seed, object_poses=object_poses, randomization=randomization
            )
            self.episode_index, self.seed = int(episode_index), seed
            if saved is not None:
                self.data.qpos[self.layout_qadr], self.data.qvel[self.layout_dadr] = saved[:2]
                self.data.ctrl[:] = saved[2]
                mujoco.mj_forward(self.model, self.data)
            elif hasattr(self, "arms"):
                for side in self.sides:
                    self.arms[side] = ArmState(self.measured(side), self.arms[side].limits)

    @property
    def scene_randomization(self) -> dict[str, Any] | None:
        """What the running episode's scene was randomized by (None: the nominal scene)."""
        return self.sampler.randomization

    def object_poses(self) -> dict[str, np.ndarray]:
        """Object name -> pose (7,) now, in the task's ``env_state`` order."""
        return self.task.object_poses()

    def env_state(self) -> np.ndarray:
        """Object poses now, 7 values each."""
        poses = list(self.object_poses().values())
        return np.concatenate(poses) if poses else np.zeros(0)

    # -- state ----------------------------------------------------------------------------
    def measured(self, side: str) -> np.ndarray:
        """Measured driver values of one arm (7,): joints (rad), actuated carriage (m)."""
        return self.data.qpos[self.qadr[side]].copy()

    def setpoint(self, side: str) -> np.ndarray:
        """Where the robot layer has one arm's 7 controls now (rad / m): its targets, rate
        limited."""
        return self.data.ctrl[self.act[side]].copy()

    def action(self) -> np.ndarray:
        """The commanded targets as a 16-value kit-layout action (gripper in both fingers)."""
        out = np.empty(VENDOR16_LAYOUT.size)
        for side in SIDES:
            t = self.arms[side].target
            out[VENDOR16_LAYOUT.arm(side)] = t[:6]
            out[VENDOR16_LAYOUT.fingers(side)] = t[6]
        return out

    def joint_commands(self, vector: np.ndarray) -> dict[str, np.ndarray]:
        """The robot's commands (move group -> targets) of the arms' 7-value targets."""
        return VENDOR16_LAYOUT.joint_commands(self.action())

    # -- stepping -------------------------------------------------------------------------
    def _tick(self) -> None:
        d = self.data
        vector = np.empty(7 * len(self.sides))
        for a, side in enumerate(self.sides):
            arm, dof = self.arms[side], self.dadr[side]
            limp = (arm.modes == EXTERNAL_EFFORT) | (arm.modes == EFFORT)
            d.qfrc_applied[dof] = 0.0
            if limp.any():
                arm.target[limp] = d.qpos[self.qadr[side]][limp]
                force = arm.effort.copy()
                raw = arm.modes == EFFORT  # no gravity compensation in effort mode
                force[raw] -= d.qfrc_gravcomp[dof][raw]
                d.qfrc_applied[dof[limp]] = force[limp]
            if arm.limits is not None and self.on_fault is not None and self.pacer.on_time:
                self._check_lag(side, arm)
            vector[7 * a : 7 * a + 7] = arm.target
        if self._batch is not None:
            self.robot.update_control(self._batch.commands(vector))
        else:
            self.robot.update_control(self.joint_commands(vector))
        self.scene.step(1)

    def _check_lag(self, side: str, arm: ArmState) -> None:
        fault = lag_fault_of(arm.modes, arm.target, self.data.ctrl[self.act[side]], arm.limits)
        if fault is not None:
            arm.modes[:] = IDLE
            arm.target[:] = self.setpoint(side)  # stop where the setpoint is
            self.on_fault(side, fault)

    def _frame(self, pace: Callable[[], None] | None) -> Frame:
        with self.lock:
            if self.before_frame is not None:
                self.before_frame()
            d = self.data
            frame = Frame(
                time=float(d.time),
                qpos_full=d.qpos.copy(),
                mocap_pos=d.mocap_pos.copy(),
                mocap_quat=d.mocap_quat.copy(),
                qpos=d.qpos[self.layout_qadr].copy(),
                qvel=d.qvel[self.layout_dadr].copy(),
                env_state=self.env_state(),
                action=self.action(),
            )
        for _ in range(self.ticks_per_frame):
            with self.lock:
                self._tick()
            if pace is not None:
                pace()
        with self.lock:
            frame.reward = float(self.task.get_reward())
            frame.success = bool(self.task.judge_success())
            self.frames += 1
            if self.on_frame is not None:
                self.on_frame(frame)
            for listener in list(self.frame_listeners):
                listener(frame)
        return frame

    def advance(self, seconds: float) -> None:
        """Step whole frames covering ``seconds`` of simulated time, unpaced (tests)."""
        for _ in range(max(1, int(round(seconds / self.frame_dt)))):
            self._frame(None)

    def start(self) -> None:
        """Step in a daemon thread, paced to wall-clock time."""
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="kit-world", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        self.pacer.start()
        try:
            while not self._stop.is_set():
                self._frame(self.pacer.pace)
        finally:
            self.pacer.stop()

    def stop(self) -> None:
        """Stop the stepping thread (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(5.0)
            self._thread = None

    @property
    def realtime_factor(self) -> float:
        """Simulated over wall-clock time while stepping in the thread (1.0: real time)."""
        return self.pacer.realtime_factor

    def close(self) -> None:
        """Stop stepping and release the sampler's scene."""
        self.stop()
        self.sampler.close()
