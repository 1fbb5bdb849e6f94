"""The arm controller's wire protocol for one served arm: ``trossen_arm_sim``'s server, completed.

:class:`ArmServer` subclasses ``trossen_arm_sim.TrossenArmSimServer`` (TCP 50001, UDP
50000) through :class:`~.serving.LoopbackArmServer` and adds what a served kit needs: every
mode goes to the arm (:class:`~.arm_adapter.ArmAdapter`); faults like hardware
(:mod:`.faults`), cleared only by ``configure(..., clear_error=True)``; joint limits read
and replaced; and session events (``on_event("connect" / "disconnect", ...)``).

Docs: docs/cli/serve.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from trossen_arm_mujoco.twin.serving import LoopbackArmServer, logger

__all__ = ["ArmServer", "EventHook"]

try:
    from trossen_arm_sim.protocol import (
        JOINT_INPUT_STRUCT,
        OUTPUT_HEADER_STRUCT,
        ConfigurationAddress,
        ErrorState,
        Mode,
        TCPCommand,
        UDPCommand,
        pack_handshake_response,
    )
except ImportError:  # the optional package is missing: require_sim_server says so
    pass

from trossen_arm_mujoco.real.controller_checks import Fault  # noqa: E402
from trossen_arm_mujoco.twin.faults import pack_limits, unpack_limits  # noqa: E402

#: (event, text) -> None: "connect", "disconnect", "fault", "clear".
EventHook = Callable[[str, str], None]


class ArmServer(LoopbackArmServer):
    """The wire protocol of one served arm; see the module doc.

    Args:
        adapter: the arm (``ArmAdapter``: ``handle_input``, ``set_modes``, ``idle``,
            ``limits``, ``set_limits``, ``read_joint_outputs``).
        host: IPv4 loopback address (TCP 50001 and UDP 50000 on it).
        name: what messages call it, e.g. ``"left arm"``.
        on_event: called with ``(event, text)`` on connect, disconnect, fault and clear.
    """

    # The driver waits 1 ms for each answer; 0.5 ms keeps its cycle at about 2 kHz, far
    # below upstream's 5 kHz, sparing a core per arm, without timing it out.
    CYCLE_PERIOD_S = 0.0005

    def __init__(self, adapter, host: str, name: str = "arm", on_event: EventHook | None = None):
        super().__init__(adapter, host, name)
        self.adapter = adapter
        self.on_event = on_event
        self.connected = False

    def _event(self, kind: str, text: str) -> None:
        logger.info("%s: %s", self.name, text)
        if self.on_event is not None:
            self.on_event(kind, text)

    # -- error state --------------------------------------------------------------------
    def fault(self, error_state, reason: str) -> None:
        """Enter ``error_state`` (an ``ErrorState`` or its value): joints idle, inputs
        ignored until a client clears it."""
        state = ErrorState(int(error_state))
        super().fault(state, reason)
        self.adapter.idle()
        self._event("fault", f"{state.name}: {reason}")

    def clear_error(self) -> None:
        """Clear the arm's error state, as the driver asks; a cleared error is reported as
        a session event."""
        was = self.error_state
        super().clear_error()
        if was != ErrorState.NONE:
            self._event("clear", f"error state {ErrorState(was).name} cleared")

    # -- TCP ----------------------------------------------------------------------------
    def _client_connected(self) -> None:
        self.connected = True
        self._event("connect", "client connected")

    def _client_disconnected(self) -> None:
        self.connected = False
        self.adapter.idle()
        self._event("disconnect", "client disconnected")

    def _handle_tcp_request(self, request: bytes) -> bytes:
        try:
            command = TCPCommand(request[0])
        except (ValueError, IndexError):
            self.fault(ErrorState.INVALID_ROBOT_COMMAND, f"unknown TCP command {request[:1]!r}")
            return bytes([self.error_state])
        if command == TCPCommand.HANDSHAKE:  # keeps the error state, as the controller does
            return pack_handshake_response(self.error_state, self.model, self.driver_version)
        try:
            return super()._handle_tcp_request(request)
        except (ValueError, IndexError, NotImplementedError) as exc:
            self.fault(ErrorState.INVALID_CONFIGURATION_ADDRESS, f"{command.name}: {exc}")
            return bytes([self.error_state])

    def _apply_configuration(self, address, payload: bytes) -> None:
        if address == ConfigurationAddress.ERROR_STATE:
            self.clear_error()
        elif self.error_state != ErrorState.NONE:
            return  # in the error state only clearing it is accepted
        elif address == ConfigurationAddress.MODES:
            try:
                modes = [Mode(b) for b in payload[: self.num_joints]]
            except ValueError:
                self.fault(ErrorState.INVALID_MODE, f"invalid modes {list(payload)}")
                return
            self.modes = modes
            self.adapter.set_modes([int(m) for m in modes])
        elif address == ConfigurationAddress.JOINT_LIMITS:
            self.adapter.set_limits(unpack_limits(payload, self.num_joints))
        else:
            super()._apply_configuration(address, payload)

    def _read_configuration(self, address) -> bytes:
        if address == ConfigurationAddress.JOINT_LIMITS:
            return pack_limits(self.adapter.limits)
        return super()._read_configuration(address)

    # -- UDP ----------------------------------------------------------------------------
    def _pack_output(self) -> bytes:
        """The robot output datagram: error state, header, then per joint position,
        velocity, effort, external effort and two temperatures (float32 each), packed
        from the arm's arrays at once."""
        self._output_id += 1
        stamp = int((time.monotonic() - self._start_time) * 1e6)
        header = OUTPUT_HEADER_STRUCT.pack(self._output_id & 0xFFFFFFFF, stamp)
        return bytes([self.error_state]) + header + self.adapter.output_table().tobytes()

    def _handle_datagram(self, datagram: bytes) -> None:
        """Check and apply one robot input; faults instead of raising."""
        now = time.monotonic()
        if datagram[0] == UDPCommand.GET_ROBOT_OUTPUT:
            return
        if datagram[0] != UDPCommand.SET_ROBOT_INPUT:
            self.fault(ErrorState.INVALID_ROBOT_COMMAND, f"unknown UDP command {datagram[0]}")
            return
        size = JOINT_INPUT_STRUCT.size
        if len(datagram) != 1 + self.num_joints * size:
            self.fault(
                ErrorState.INVALID_ROBOT_COMMAND,
                f"robot input of {len(datagram)} bytes, expected {1 + self.num_joints * size}",
            )
            return
        if self.error_state != ErrorState.NONE:
            return  # joints idle until the error is cleared
        modes, values = [], []
        for j in range(self.num_joints):
            mode, a, b, c = JOINT_INPUT_STRUCT.unpack_from(datagram, 1 + j * size)
            if mode not in Mode._value2member_map_:
                self.fault(ErrorState.INVALID_MODE, f"joint {j}: invalid mode {mode}")
                return
            if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c)):
                bad = f"joint {j}: robot input with a non-finite value ({a}, {b}, {c})"
                self.fault(ErrorState.ROBOT_INPUT_INFINITE, bad)
                return
            modes.append(mode)
            values.append(_values(mode, a, b))
        fault: Fault | None = self.adapter.handle_input(modes, values, now)
        if fault is not None:
            self.fault(fault.state, fault.reason)


def _values(mode: int, a: float, b: float) -> tuple[float, float, float]:
    """``(position, velocity, effort)`` of one joint input, its fields read per mode as
    ``JointInput.parse`` does (position mode: position, feedforward velocity)."""
    return {
        Mode.POSITION: (a, b, 0.0),
        Mode.VELOCITY: (0.0, a, 0.0),
        Mode.EXTERNAL_EFFORT: (0.0, 0.0, a),
        Mode.EFFORT: (0.0, 0.0, a),
    }.get(mode, (0.0, 0.0, 0.0))
