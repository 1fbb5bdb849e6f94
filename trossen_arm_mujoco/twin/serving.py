"""What serving a simulated arm needs: the optional protocol package, a loopback address,
sockets that wake the threads blocked on them when shut, and the server both kinds of served
arm build on.

:class:`LoopbackArmServer` subclasses ``trossen_arm_sim.TrossenArmSimServer`` (the arm
controller's wire protocol: TCP 50001 for the handshake and configuration, UDP 50000 for the
realtime cycle, both on the server's own address) with what every served arm needs, so that
servers can be started and stopped many times in one process (tests, ``serve``, leaders):

- **Loopback only**: the address must be IPv4 in 127.0.0.0/8 (:func:`check_loopback`, a
  one-line ``UserError`` otherwise); an address that is taken is a one-line ``UserError``
  too (the UDP socket is never shared: no ``SO_REUSEADDR`` on it).
- **A stop that ends its threads**: upstream's ``stop()`` only closes the sockets, which on
  Linux wakes neither a thread blocked in ``accept`` nor one blocked in ``recvfrom``, nor
  the thread serving a connected client. Here the sockets are shut down first (that wakes
  them), the UDP loop also polls with a timeout, and :meth:`~LoopbackArmServer.stop` joins
  every thread.
- **No thread dies on bad input**: a TCP client whose request cannot be served is
  disconnected; a datagram whose handling raises is dropped (logged) and serving goes on;
  only the newest waiting datagram is answered (the driver gave up on older ones).

:class:`~.arm_server.ArmServer` (a follower arm of the served kit) and
:class:`~.leader_server.LeaderArmServer` (a simulated leader arm) specialise it.
"""

from __future__ import annotations

import importlib
import logging
import socket
import threading
import time
from typing import Any

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.real.preflight import check_loopback

__all__ = [
    "INSTALL_HINT",
    "JOIN_TIMEOUT_S",
    "MAX_DATAGRAM",
    "UDP_ERROR_PAUSE_S",
    "UDP_POLL_S",
    "LoopbackArmServer",
    "check_loopback",
    "require_sim_server",
    "shut",
]

try:
    from trossen_arm_sim import TrossenArmSimServer
    from trossen_arm_sim.protocol import TCP_PORT, UDP_PORT
except ImportError:  # the optional package is missing: require_sim_server says so
    TrossenArmSimServer = object  # type: ignore[assignment,misc]
    TCP_PORT, UDP_PORT = 50001, 50000

#: How to install the package that provides the protocol layer.
INSTALL_HINT = "pip install 'trossen-arm-mujoco[twin]' (trossen-arm-sim==0.2.3)"

logger = logging.getLogger("trossen_arm_mujoco.twin")
# Faults and connections are reported through the servers' hooks; without a handler
# configured, Python's last-resort handler would also print upstream's and these records.
for _name in ("trossen_arm_sim", logger.name):
    logging.getLogger(_name).addHandler(logging.NullHandler())

#: A blocked UDP receive wakes up this often (s) to see whether the server was stopped.
UDP_POLL_S: float = 0.2
#: Pause (s) after a receive error while serving, so a broken socket never spins a core.
UDP_ERROR_PAUSE_S: float = 0.001
#: How long ``stop`` waits for each thread (s).
JOIN_TIMEOUT_S: float = 2.0
#: Largest datagram read (bytes); a robot input of 7 joints is 113.
MAX_DATAGRAM: int = 4096


def require_sim_server() -> None:
    """A one-line ``UserError`` with the install command when ``trossen_arm_sim`` (or the
    ``trossen_arm`` it needs) cannot be imported."""
    try:
        importlib.import_module("trossen_arm_sim.server")
    except ImportError as exc:
        raise UserError(
            f"serving the kit needs the 'trossen_arm_sim' package, which cannot be imported "
            f"({exc}): {INSTALL_HINT}"
        ) from None


def shut(sock: socket.socket | None) -> None:
    """Shut ``sock`` down (waking threads blocked on it) and close it; never raises."""
    if sock is None:
        return
    try:
        sock.shutdown(socket.SHUT_RDWR)
    except OSError:
        pass  # not connected: a listening or UDP socket is woken all the same on Linux
    try:
        sock.close()
    except OSError:
        pass


class LoopbackArmServer(TrossenArmSimServer):  # type: ignore[misc,valid-type]
    """The wire protocol of one simulated arm on a loopback address; see the module doc.

    Subclasses handle a robot input in ``_handle_datagram`` (raising drops the datagram) and
    may hook a client's connection (:meth:`_client_connected`, :meth:`_client_disconnected`).

    Args:
        arm: the simulated arm, as upstream's server takes it (``num_joints``, ...).
        host: IPv4 loopback address to listen on (TCP 50001, UDP 50000).
        name: what messages call this server, e.g. ``"left arm"``.
    """

    def __init__(self, arm: Any, host: str, name: str = "arm") -> None:
        require_sim_server()
        host = check_loopback(host, f"{name} address")
        try:
            super().__init__(arm, host=host)
        except ValueError as exc:  # an installed trossen_arm whose protocol it does not speak
            raise UserError(f"{exc}: pip install 'trossen-arm>=1.9.1,<1.12'") from None
        self.name = name
        self._clients: set[socket.socket] = set()
        self._clients_lock = threading.Lock()

    # -- life cycle ---------------------------------------------------------------------
    def start(self) -> None:
        """Bind both sockets and serve in daemon threads; a one-line ``UserError`` when the
        address cannot be bound (taken by another server, or not configured)."""
        self._running = True
        try:
            self._tcp_socket = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            self._tcp_socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self._tcp_socket.bind((self.host, TCP_PORT))
            self._tcp_socket.listen(1)
            self._udp_socket = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            self._udp_socket.bind((self.host, UDP_PORT))  # no SO_REUSEADDR: never shared
        except OSError as exc:
            self.stop()
            raise UserError(
                f"cannot serve the {self.name} on {self.host} (TCP {TCP_PORT}, UDP {UDP_PORT}): "
                f"{exc.strerror or exc}; is another server running there? stop it or choose "
                "another loopback address"
            ) from None
        for target, kind in ((self._tcp_loop, "tcp"), (self._udp_loop, "udp")):
            thread = threading.Thread(target=target, daemon=True, name=f"{self.name}-{kind}")
            thread.start()
            self._threads.append(thread)

    def stop(self) -> None:
        """Stop serving: wake and join every thread, close every socket (idempotent)."""
        self._running = False
        with self._clients_lock:
            clients = list(self._clients)
        for sock in (self._tcp_socket, self._udp_socket, *clients):
            shut(sock)
        self._tcp_socket = self._udp_socket = None
        for thread in self._threads:
            if thread is not threading.current_thread():
                thread.join(JOIN_TIMEOUT_S)
        self._threads = [t for t in self._threads if t.is_alive()]

    @property
    def alive_threads(self) -> int:
        """Server threads still running (0 after :meth:`stop`)."""
        return sum(t.is_alive() for t in self._threads)

    def __enter__(self) -> LoopbackArmServer:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- TCP: one client at a time, remembered so that stop() can disconnect it ---------
    def _client_connected(self) -> None:
        """Called when a client's TCP connection opens."""

    def _client_disconnected(self) -> None:
        """Called when a client's TCP connection has closed."""

    def _tcp_loop(self) -> None:
        listener = self._tcp_socket
        while self._running and listener is not None:
            try:
                conn, _ = listener.accept()
            except OSError:
                return  # shut down by stop()
            with self._clients_lock:
                self._clients.add(conn)
            self._client_connected()
            try:
                if self._running:
                    self._serve_tcp_client(conn)
            except (OSError, ValueError, KeyError, IndexError, NotImplementedError) as exc:
                logger.info("%s: TCP client dropped: %s", self.name, exc)
            finally:
                with self._clients_lock:
                    self._clients.discard(conn)
                shut(conn)
                self._client_disconnected()

    # -- UDP: the realtime cycle, polling so that stop() is seen ------------------------
    def _udp_loop(self) -> None:
        sock = self._udp_socket
        if sock is None:
            return
        while self._running:
            try:
                sock.settimeout(UDP_POLL_S)
                datagram, source = sock.recvfrom(MAX_DATAGRAM)
                datagram, source = self._newest(sock, datagram, source)
            except TimeoutError:
                continue
            except OSError:
                # shut down by stop(), or an ICMP error from a client that went away (an
                # answer to a closed port): keep serving unless stopped
                if not self._running:
                    return
                time.sleep(UDP_ERROR_PAUSE_S)
                continue
            if not self._running:
                return
            if not datagram:
                continue
            try:
                self._handle_datagram(datagram)
                sock.sendto(self._pack_output(), source)
            except OSError:
                if not self._running:
                    return
                continue
            except Exception as exc:  # a malformed datagram: drop it, keep serving
                logger.info("%s: dropped a datagram: %s", self.name, exc)
                continue
            self._pace_cycle()

    def _newest(self, sock: socket.socket, datagram: bytes, source: Any) -> tuple[bytes, Any]:
        """The newest datagram waiting on ``sock`` (``datagram`` when none): the driver has
        given up on older requests, and answering them would feed it stale outputs."""
        sock.settimeout(0.0)
        while self._running:
            try:
                datagram, source = sock.recvfrom(MAX_DATAGRAM)
            except OSError:  # none left (BlockingIOError), or an ICMP error: keep the last
                break
        return datagram, source

    def _handle_datagram(self, datagram: bytes) -> None:
        """Apply one robot input (raising drops it unanswered)."""
        raise NotImplementedError
