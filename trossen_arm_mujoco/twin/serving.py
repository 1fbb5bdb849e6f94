"""What serving a simulated arm needs: the optional protocol package, a loopback address,
sockets that wake the threads blocked on them when shut, and the server both kinds of served
arm build on.

:class:`LoopbackArmServer` subclasses ``trossen_arm_sim.TrossenArmSimServer`` (TCP 50001,
UDP 50000, on the server's own address) with loopback addresses only (:func:`check_loopback`),
a stop that ends its threads, no thread dying on bad input and listeners that outlast a
burst of clients (:class:`Acceptor`). :class:`~.arm_server.ArmServer` and
:class:`~.leader_server.LeaderArmServer` specialise it.

Docs: docs/cli/serve.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import errno
import importlib
import logging
import os
import socket
import struct
import threading
import time
from typing import Any

from trossen_arm_mujoco.errors import UserError, describe_os_error
from trossen_arm_mujoco.real.preflight import check_loopback

__all__ = [
    "ACCEPT_PAUSE_S",
    "INSTALL_HINT",
    "JOIN_TIMEOUT_S",
    "LISTEN_BACKLOG",
    "MAX_DATAGRAM",
    "UDP_ERROR_PAUSE_S",
    "UDP_POLL_S",
    "Acceptor",
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


#: Connections a TCP listener queues before they are accepted (the kernel caps it at
#: net.core.somaxconn): a burst of clients waits instead of being dropped.
LISTEN_BACKLOG: int = socket.SOMAXCONN
#: Pause (s) after an accept that failed for want of file descriptors or memory.
ACCEPT_PAUSE_S: float = 0.05
#: ``accept`` errors that mean "not now" (resources), not "the listener is gone".
OUT_OF_RESOURCES = frozenset({errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM})


def _spare_descriptor() -> int | None:
    """A file descriptor held in reserve (``/dev/null``), None when none is left."""
    try:
        return os.open(os.devnull, os.O_RDONLY | getattr(os, "O_CLOEXEC", 0))
    except OSError:
        return None


class Acceptor:
    """``accept`` on a TCP listener, surviving a shortage of file descriptors.

    When ``accept`` fails with EMFILE / ENFILE / ENOBUFS / ENOMEM the waiting connection
    would stay queued and every later ``accept`` fail alike (a loop that spins, or a thread
    that ends and takes the listener with it). Here one descriptor is held in reserve: it is
    released to accept that connection, which is closed at once (refused: the client sees a
    reset), then taken again; one line is logged per run of failures, and the call pauses
    ``pause`` s (``wait``) before returning None. Call :meth:`close` when done.

    Args:
        listener: the listening socket.
        name: what the log line calls it, e.g. ``"left arm"``.
        log: where the line goes.
        wait: the pause (``time.sleep``, or a stop event's ``wait``).
        pause: seconds to pause after a refused connection.
    """

    def __init__(
        self,
        listener: socket.socket,
        name: str,
        log: logging.Logger = logger,
        wait: Any = time.sleep,
        pause: float = ACCEPT_PAUSE_S,
    ) -> None:
        self.listener, self.name, self.log, self.wait, self.pause = listener, name, log, wait, pause
        self.refused = 0
        self._failing = False
        self._spare = _spare_descriptor()

    def accept(self) -> socket.socket | None:
        """The next client's connection; None when none could be accepted now (refused, or
        gone before it was accepted). Raises ``OSError`` when the listener was shut."""
        try:
            conn, _ = self.listener.accept()
        except OSError as exc:
            if exc.errno == errno.ECONNABORTED:  # the client left while queued
                return None
            if exc.errno not in OUT_OF_RESOURCES:
                raise
            self._refuse(exc)
            return None
        self._failing = False
        return conn

    def _refuse(self, exc: OSError) -> None:
        self.refused += 1
        if not self._failing:
            self._failing = True
            self.log.warning(
                "%s: cannot accept a connection (%s): refused it; still serving",
                self.name,
                describe_os_error(exc),
            )
        if self._spare is not None:  # make room to take the waiting one off the queue
            os.close(self._spare)
            self._spare = None
            try:
                conn, _ = self.listener.accept()
            except OSError:
                pass
            else:
                try:  # a reset, not an end of stream: refused
                    conn.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
                except OSError:
                    pass
                conn.close()
            self._spare = _spare_descriptor()
        self.wait(self.pause)

    def close(self) -> None:
        """Release the descriptor held in reserve (idempotent)."""
        if self._spare is not None:
            os.close(self._spare)
            self._spare = None


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
            self._tcp_socket.listen(LISTEN_BACKLOG)
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
        if listener is None:
            return
        acceptor = Acceptor(listener, self.name)
        try:
            self._accept_clients(acceptor)
        finally:
            acceptor.close()

    def _accept_clients(self, acceptor: Acceptor) -> None:
        while self._running:
            try:
                conn = acceptor.accept()
            except OSError:
                return  # shut down by stop()
            if conn is None:  # refused for want of descriptors: serving goes on
                continue
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
