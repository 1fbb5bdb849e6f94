"""One simulated leader arm controller on a loopback address, that stops cleanly.

:class:`LeaderArmServer` is :class:`~.serving.LoopbackArmServer` (``trossen_arm_sim``'s
``TrossenArmSimServer``, loopback only, a stop that ends every thread, no thread dying on
a bad request), so that a pair of them can be started and stopped many times in one
process (tests, ``serve_leaders``), applying robot inputs as upstream does: each joint's
mode and position go to the arm, and a malformed datagram is dropped.

The arm behind the server is any object with ``num_joints``, ``joint_limits`` (list of
``(low, high)``: rad for the 6 joints, m for the gripper), ``apply_joint_commands(modes,
positions)`` and ``read_joint_outputs()`` (a list of ``trossen_arm_sim.protocol.JointOutput``),
as upstream's server takes.

Docs: docs/cli/serve.md, docs/cli/teleop.md.
"""

from __future__ import annotations

from trossen_arm_mujoco.twin.serving import LoopbackArmServer

__all__ = ["LeaderArmServer"]

try:
    from trossen_arm_sim.protocol import UDPCommand, parse_robot_input
except ImportError:  # pragma: no cover - the optional package is missing: require_sim_server
    pass


class LeaderArmServer(LoopbackArmServer):
    """The arm controller's wire protocol for ``arm`` on the loopback address ``host``.

    Args:
        arm: the simulated arm (see the module docstring).
        host: IPv4 loopback address to listen on (TCP 50001, UDP 50000).
        name: what messages call this server, e.g. ``"left leader arm"``.
    """

    def _handle_datagram(self, datagram: bytes) -> None:
        """Apply a robot input (joint modes and commands) to the arm; other commands only
        ask for the robot output."""
        if datagram[0] == UDPCommand.SET_ROBOT_INPUT:
            inputs = parse_robot_input(datagram[1:], self.num_joints)
            self.sim.apply_joint_commands(
                [joint.mode for joint in inputs], [joint.position for joint in inputs]
            )
