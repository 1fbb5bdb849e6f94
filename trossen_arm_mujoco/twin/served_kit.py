"""The served kit: one world, both arms on their own loopback addresses, started and stopped
together.

:class:`ServedKit` puts the two arms of a :class:`~.kit_world.KitWorld` behind an
:class:`~.arm_server.ArmServer` each (left on ``ips["left"]``, right on ``ips["right"]``,
TCP 50001 and UDP 50000 on each address), steps the world in real time, and tells an
optional :class:`~.session_recorder.SessionRecorder` when a client session opens (a first
client connects) and closes (the last one disconnects). Events (connections, faults) are
reported in one line each through ``say``. A ``with`` block starts and stops it; ``stop``
ends every thread it started.

    >>> with ServedKit(KitWorld(), {"left": "127.0.0.2", "right": "127.0.0.3"}) as kit:
    ...     ...  # any trossen_arm client drives the arms meanwhile

Docs: docs/cli/serve.md.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Collection, Mapping, Sequence

import numpy as np

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.robot.layout import SIDES
from trossen_arm_mujoco.twin.arm_adapter import ArmAdapter
from trossen_arm_mujoco.twin.arm_server import ArmServer
from trossen_arm_mujoco.twin.kit_world import KitWorld
from trossen_arm_mujoco.twin.serving import check_loopback
from trossen_arm_mujoco.twin.session_recorder import RecordStats, SessionRecorder

__all__ = ["DEFAULT_IPS", "ServedKit", "check_kit_ips", "kit_for_episode"]

#: Default addresses of the served follower arms.
DEFAULT_IPS: dict[str, str] = {"left": "127.0.0.2", "right": "127.0.0.3"}


def check_kit_ips(
    ips: Mapping[str, str],
    flags: Mapping[str, str] | None = None,
    sides: Sequence[str] = SIDES,
) -> dict[str, str]:
    """The arms' addresses (the kit's two; ``sides``: those of another world, e.g. the
    single arm's ``("follower",)``), checked: IPv4 loopback and different (one-line
    ``UserError`` otherwise). ``flags``: the flag naming each address, for messages.

    Args:
        ips: side -> address.
        flags: side -> the flag that gave its address, for messages.
        sides: the sides to check (the kit's two, or another world's).

    Raises:
        UserError: an address that is not IPv4 loopback, or one given twice.
    """
    flags = flags or {side: f"{side} arm address" for side in sides}
    out = {side: check_loopback(ips[side], flags[side]) for side in sides}
    if tuple(sides) == SIDES and out["left"] == out["right"]:
        raise UserError(
            f"{flags['left']} and {flags['right']} are both {out['left']}; each arm needs "
            "its own address (e.g. 127.0.0.2 and 127.0.0.3)"
        )
    return out


def kit_for_episode(
    attrs: Mapping[str, object], ips: Mapping[str, str], say: Callable[[str], None] | None = None
) -> ServedKit:
    """A served kit (not started) set up like a recorded episode's scene: its task
    (``task_name`` when it is a kit task, else ``sim_transfer_cube``) with the objects at
    the episode's recorded start (``initial_env_state`` and ``object_names``, when present
    and matching the task), e.g. to replay the episode through the wire. Only faults and
    their clearing are reported through ``say``.

    Args:
        attrs: the episode file's attributes (``task_name``, ``initial_env_state``,
            ``object_names``).
        ips: side -> loopback address.
        say: gets a line per fault and its clearing (None: silent).
    """
    from trossen_arm_mujoco.tasks import registry

    task = str(attrs.get("task_name", ""))
    task = task if task in registry.kit_names() else registry.DEFAULT_TASK
    world = KitWorld(task)
    names, state = attrs.get("object_names"), attrs.get("initial_env_state")
    if names is not None and state is not None:
        names = [str(n) for n in names]  # type: ignore[union-attr]
        flat = np.asarray(state, dtype=np.float64).reshape(-1)
        if names == list(world.object_poses()) and flat.size == 7 * len(names):
            poses = {n: flat[7 * i : 7 * i + 7] for i, n in enumerate(names)}
            world.reset(0, object_poses=poses)
    return ServedKit(world, ips, say, report=("fault", "clear"))


class ServedKit:
    """Both arms of ``world`` served on ``ips``; see the module doc. A single arm's world
    (``twin.arm_world.ArmWorld``) is served the same way: its one arm on ``ips["follower"]``.

    Args:
        world: the kit world (stepped by the kit from :meth:`start` to :meth:`stop`).
        ips: ``{"left": ip, "right": ip}``, distinct IPv4 loopback addresses (one per arm
            of ``world.sides``).
        say: prints one line per event; default: nothing.
        recorder: told of client sessions; stopped (its queue written) by :meth:`stop`.
        report: the events ``say`` gets: ``connect``, ``disconnect``, ``fault``, ``clear``.
    """

    def __init__(
        self,
        world: KitWorld,
        ips: Mapping[str, str],
        say: Callable[[str], None] | None = None,
        recorder: SessionRecorder | None = None,
        report: Collection[str] = ("connect", "disconnect", "fault", "clear"),
    ) -> None:
        self.sides = tuple(world.sides)
        self.world, self.ips = world, check_kit_ips(ips, sides=self.sides)
        self.say, self.recorder, self.report = say, recorder, frozenset(report)
        self.adapters = {side: ArmAdapter(world, side) for side in self.sides}
        self.servers = {
            side: ArmServer(
                self.adapters[side], self.ips[side], f"{side} arm", on_event=self._hook(side)
            )
            for side in self.sides
        }
        world.on_fault = self._motion_fault
        self.faults: list[str] = []
        self._connected: set[str] = set()
        self._lock = threading.Lock()
        self._started = False
        self.record_stats: RecordStats | None = None
        #: Client sessions delimit the recorder's episodes (False: the episode control
        #: channel's start / end do, ``episode_control``).
        self.sessions_from_clients = True

    def _hook(self, side: str) -> Callable[[str, str], None]:
        def on_event(kind: str, text: str) -> None:
            with self._lock:
                was_open = bool(self._connected)
                if kind == "connect":
                    self._connected.add(side)
                elif kind == "disconnect":
                    self._connected.discard(side)
                elif kind == "fault":
                    self.faults.append(f"{side} arm: {text}")
                is_open = bool(self._connected)
            if self.recorder is not None and self.sessions_from_clients and is_open != was_open:
                if is_open:
                    self.recorder.session_started()
                else:
                    self.recorder.session_ended()
            if self.say is not None and kind in self.report:
                self.say(f"{side} arm ({self.ips[side]}): {text}")

        return on_event

    def _motion_fault(self, side: str, fault) -> None:
        """The world found an arm's target too far ahead of its setpoint: fault its server
        (stepping thread)."""
        self.servers[side].fault(fault.state, fault.reason)

    @property
    def connected(self) -> list[str]:
        """Arms with a connected client."""
        with self._lock:
            return [s for s in self.sides if s in self._connected]

    def start(self) -> ServedKit:
        """Serve both arms and step the world; a one-line ``UserError`` (nothing left
        running) when an address cannot be bound."""
        try:
            for side in self.sides:
                self.servers[side].start()
        except BaseException:
            for server in self.servers.values():
                server.stop()
            raise
        self.world.start()
        self._started = True
        return self

    def stop(self, progress: Callable[[], None] | None = None) -> RecordStats | None:
        """Disconnect the clients, stop serving and stepping, finish the recording (its
        queued frames are written, however long that takes; ``progress`` is called every
        fraction of a second meanwhile); idempotent. Returns the recording's totals, if
        any."""
        self.world.stop()
        for server in self.servers.values():
            server.stop()
        if self.recorder is not None and self.record_stats is None:
            self.record_stats = self.recorder.stop(progress)
        self._started = False
        return self.record_stats

    def close(self) -> RecordStats | None:
        """:meth:`stop`, then release the world (its scene and renderers)."""
        stats = self.stop()
        self.world.close()
        return stats

    @property
    def alive_threads(self) -> int:
        """Server threads still running (0 after :meth:`stop`)."""
        return sum(s.alive_threads for s in self.servers.values())

    def __enter__(self) -> ServedKit:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
