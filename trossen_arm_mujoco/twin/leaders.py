"""Simulated leader arms: a recorded episode played back over the arm controller's protocol.

A pair of leader arms (left, right), each served on its own loopback address by a
:class:`~trossen_arm_mujoco.twin.leader_server.LeaderArmServer`, reports the joint positions
of a recorded episode as if a person were moving them: any ``trossen_arm`` client reads them
with ``get_all_positions()``, 7 values per arm (6 joints rad, then the gripper m: one
finger's travel, 0 closed .. 0.044 open). ``source`` picks the episode's actions (default)
or its ``qpos``; the replay starts once a client put both arms in ``external_effort`` mode
(or on :meth:`LeaderPair.trigger`), after ``lead_in`` s, at ``speed``; :func:`serve_leaders`
serves a pair.

Docs: docs/cli/serve.md, docs/cli/teleop.md; the replay's rules: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
import sys
import threading
from collections.abc import Callable

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.validate import ArmLimits
from trossen_arm_mujoco.robot.layout import SIDES
from trossen_arm_mujoco.twin.leader_server import LeaderArmServer
from trossen_arm_mujoco.twin.leader_trajectory import LeaderTrajectory, load_leader_trajectory
from trossen_arm_mujoco.twin.replay_clock import LEAD_IN_S, ReplayClock, check_speed
from trossen_arm_mujoco.twin.serving import check_loopback, require_sim_server

__all__ = [
    "APPROACH_SPEED_FRACTION",
    "DEFAULT_LEADER_IPS",
    "EXTERNAL_EFFORT_MODE",
    "POSITION_MODE",
    "LeaderPair",
    "PlayedLeaderArm",
    "serve_leaders",
]

#: Joint mode values of ``position`` and ``external_effort`` in the controller's protocol.
POSITION_MODE: int = 1
EXTERNAL_EFFORT_MODE: int = 3
#: Peak speed of the approach from a rest pose to the episode's first pose, as a fraction
#: of each joint's speed limit.
APPROACH_SPEED_FRACTION: float = 0.5
#: Default loopback addresses of the served leader pair (left, right).
DEFAULT_LEADER_IPS: tuple[str, str] = ("127.0.0.4", "127.0.0.5")


class PlayedLeaderArm:
    """One leader arm that plays its part of a :class:`LeaderTrajectory`: the object a
    :class:`LeaderArmServer` serves (``num_joints``, ``joint_limits``,
    ``apply_joint_commands``, ``read_joint_outputs``).

    Args:
        trajectory: the episode's joint values per arm.
        side: ``"left"`` or ``"right"``: its part of the trajectory.
        clock: the replay clock both arms read.
        limits: the arm's joint ranges (rad; gripper m) and speed limits.
    """

    num_joints = 7

    def __init__(
        self, trajectory: LeaderTrajectory, side: str, clock: ReplayClock, limits: ArmLimits
    ) -> None:
        from trossen_arm_sim.protocol import JointOutput

        self._output = JointOutput
        self.trajectory = trajectory
        self.side = side
        self.arm = SIDES.index(side)
        self.clock = clock
        self._limits = [
            (float(lo), float(hi))
            for lo, hi in zip(limits.driver_lower, limits.driver_upper, strict=True)
        ]
        self._low, self._high = np.asarray(self._limits).T  # for clipping a rest pose
        self._speed = np.asarray(limits.velocity, dtype=float)
        #: Where a client's position commands put the arm before the replay (None: none did;
        #: it rests at the episode's first pose).
        self.rest: np.ndarray | None = None
        #: Modes of the last robot input (protocol values; None before any).
        self.modes: list[int] | None = None
        #: Robot inputs received.
        self.inputs = 0

    @property
    def joint_limits(self) -> list[tuple[float, float]]:
        """``(low, high)`` per joint: rad x6, then the gripper (m)."""
        return list(self._limits)

    def apply_joint_commands(self, modes: list, positions: list) -> None:
        """Watch the modes (external_effort on every joint triggers the replay); before the
        trigger, position commands move the arm (its rest pose); nothing else moves it."""
        self.inputs += 1
        self.modes = [int(m) for m in modes]
        if self.modes and all(m == EXTERNAL_EFFORT_MODE for m in self.modes):
            self.clock.client_ready(self.side)
        elif (
            self.clock.start_time is None
            and len(self.modes) == self.num_joints
            and all(m == POSITION_MODE for m in self.modes)
        ):
            values = np.asarray(positions, dtype=float)
            if values.shape == (self.num_joints,) and np.all(np.isfinite(values)):
                self.rest = np.clip(values, self._low, self._high)

    def approach_time(self) -> float:
        """Seconds a smooth move (peak speed 1.5x the mean) from the rest pose to the
        episode's first pose takes at :data:`APPROACH_SPEED_FRACTION` of the speed limits;
        0 without a rest pose."""
        rest = self.rest
        if rest is None:
            return 0.0
        distance = np.abs(self.trajectory.positions[0, self.arm] - rest)
        return float(np.max(1.5 * distance / (APPROACH_SPEED_FRACTION * self._speed)))

    def now(self) -> tuple[np.ndarray, np.ndarray]:
        """Position (rad x6, m) and velocity of each joint now (see the module doc)."""
        kind, value = self.clock.phase()
        rest = self.rest
        if kind == "play" or rest is None:
            position, velocity = self.trajectory.sample(self.arm, value if kind == "play" else 0.0)
            return position, velocity * self.clock.speed
        if kind == "rest":
            return rest.copy(), np.zeros(self.num_joints)
        delta = self.trajectory.positions[0, self.arm] - rest  # approach: smoothstep
        s, ds = value * value * (3.0 - 2.0 * value), 6.0 * value * (1.0 - value)
        return rest + s * delta, ds * delta / self.clock.approach_s

    def read_joint_outputs(self) -> list:
        """The played position and velocity of each joint now (efforts 0)."""
        position, velocity = self.now()
        return [
            self._output(position=float(p), velocity=float(v))
            for p, v in zip(position, velocity, strict=True)
        ]


class LeaderPair:
    """Two played leader arms, each behind its own server on a loopback address.

    Args:
        trajectory: what to play.
        left_ip, right_ip: distinct IPv4 loopback addresses.
        speed: replay speed (1.0 = as recorded).
        lead_in: seconds the first pose is held after the trigger (see the module doc).

    Use as a context manager, or :meth:`start` / :meth:`stop`.
    """

    def __init__(
        self,
        trajectory: LeaderTrajectory,
        left_ip: str = DEFAULT_LEADER_IPS[0],
        right_ip: str = DEFAULT_LEADER_IPS[1],
        speed: float = 1.0,
        lead_in: float = LEAD_IN_S,
    ) -> None:
        require_sim_server()
        ips = {
            "left": check_loopback(left_ip, "left leader address"),
            "right": check_loopback(right_ip, "right leader address"),
        }
        if ips["left"] == ips["right"]:
            raise UserError(
                f"the left and right leader arms need two addresses, got {left_ip} twice"
            )
        check_speed(speed)
        if not (math.isfinite(lead_in) and lead_in >= 0):
            raise UserError(f"lead_in must be a non-negative number of seconds, got {lead_in!r}")
        self.trajectory = trajectory
        self.ips = ips
        self.clock = ReplayClock(trajectory.duration, speed, lead_in, approach=self._approach)
        limits = ArmLimits.from_mjcf()
        self.arms = {s: PlayedLeaderArm(trajectory, s, self.clock, limits) for s in SIDES}
        self.servers = {s: LeaderArmServer(self.arms[s], ips[s], f"{s} leader arm") for s in SIDES}

    def _approach(self) -> float:
        """Seconds both arms take from their rest poses to the episode's first pose."""
        return max(arm.approach_time() for arm in self.arms.values())

    @property
    def started(self) -> threading.Event:
        """Set once the arms have left their rest pose (the approach, or the episode)."""
        return self.clock.started

    @property
    def finished(self) -> threading.Event:
        """Set once the replay reached the episode's end (the arms hold its last pose)."""
        return self.clock.finished

    def trigger(self) -> None:
        """Start the replay now, without waiting for a client."""
        self.clock.trigger()

    def start(self) -> None:
        """Serve both arms (both or neither: a failure stops the first)."""
        try:
            for server in self.servers.values():
                server.start()
        except BaseException:
            self.stop()
            raise

    def stop(self) -> None:
        """Stop both servers (idempotent); clients see the connection drop."""
        for server in self.servers.values():
            server.stop()

    def __enter__(self) -> LeaderPair:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def serve_leaders(
    episode_path: str,
    left_ip: str,
    right_ip: str,
    stop_event: threading.Event,
    speed: float = 1.0,
    *,
    lead_in: float = LEAD_IN_S,
    source: str = "action",
    say: Callable[[str], None] | None = _say,
    on_ready: Callable[[LeaderPair], None] | None = None,
) -> None:
    """Serve a pair of leader arms replaying ``episode_path`` until ``stop_event`` is set.

    The arms hold the episode's first pose until a client puts both in external_effort mode,
    then ``lead_in`` s later play the episode at ``speed`` and hold its last pose (see the
    module docstring). ``say`` gets one line when serving starts, when the replay starts and
    when it has finished (default: stderr; None: silent). ``on_ready`` is called with the
    running :class:`LeaderPair` (its ``started`` / ``finished`` events, ``trigger()``).

    Raises:
        UserError: a non-loopback or repeated address, a bad speed, an unreadable episode,
            an address already served (one line each).

    Args:
        episode_path: the episode file to replay (this package's or a vendor recording).
        left_ip: the left leader's loopback address.
        right_ip: the right leader's loopback address.
        stop_event: serving ends when it is set.
        speed: replay speed (1.0: as recorded).
        lead_in: seconds between both arms' ``external_effort`` mode and the replay.
        source: ``"action"`` (the recorded actions) or ``"qpos"`` (the follower joints).
        say: gets one line per event (default: stderr; None: silent).
        on_ready: called with the running :class:`LeaderPair`.
    """
    trajectory = load_leader_trajectory(episode_path, source)
    speak = say or (lambda line: None)
    with LeaderPair(trajectory, left_ip, right_ip, speed, lead_in) as pair:
        speak(
            f"serving leader arms replaying {trajectory.path} ({trajectory.num_steps} steps, "
            f"{trajectory.duration / pair.clock.speed:.1f} s at speed {pair.clock.speed:g}, "
            f"{source}) on left {pair.ips['left']}, right {pair.ips['right']}; the replay "
            f"starts {lead_in:g} s after a client puts both arms in external_effort mode"
        )
        if on_ready is not None:
            on_ready(pair)
        said_start = said_end = False
        while not stop_event.wait(0.05):
            pair.clock.poll()
            if not said_start and pair.started.is_set():
                said_start = True
                speak("leader replay started")
            if not said_end and pair.finished.is_set():
                said_end = True
                speak("leader replay finished; holding the last pose")
