"""What replay needs from one arm, and the real backend over the ``trossen_arm`` driver.

Positions of one arm are 7 values: ``[joint_0 .. joint_5 (rad), gripper (m)]``. The gripper
value is the travel of **one** carriage from closed, in metres (0 closed, 0.044 fully open;
the finger gap is about twice that), as ``trossen_arm`` and the MJCF carriage joint mean it;
the arm controller limits it to 0.04 m (:mod:`.gripper`). A 16-value dataset row maps to the
driver as ``left = row[0:7]``, ``right = row[8:15]`` (:func:`split_arms`; the coupled
finger's value is not sent). ``configure`` takes a ``trossen_arm.StandardEndEffector`` name
(:func:`end_effector_presets`). :class:`TrossenArmDriver` imports ``trossen_arm`` lazily
(``pip install 'trossen-arm-mujoco[real]'``); the twin is :mod:`.sim_driver`.

Docs: docs/cli/replay-real.md, docs/real-kit.md; conventions: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import atexit
import weakref
from collections.abc import Sequence
from importlib import metadata
from types import ModuleType
from typing import Any, Protocol, runtime_checkable

import numpy as np

from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.robot.layout import VENDOR16_LAYOUT

__all__ = [
    "COMMAND_ERRORS",
    "CONNECT_TIMEOUT_S",
    "DEFAULT_END_EFFECTOR",
    "DEFAULT_MODEL",
    "HOME_POSE",
    "INSTALL_HINT",
    "NUM_ARM_VALUES",
    "SLEEP_POSE",
    "ArmDriver",
    "TrossenArmDriver",
    "check_end_effector",
    "end_effector_presets",
    "find_trossen_arm",
    "import_trossen_arm",
    "installed_version",
    "release_driver_logs",
    "resolve_presets",
    "route_driver_logs",
    "split_arms",
]

#: Values per arm sent to / read from a driver: 6 joints (rad) + gripper (m).
NUM_ARM_VALUES: int = 7

#: Home pose (7 values): the arm part of START_ARM_POSE with the gripper closed.
HOME_POSE: tuple[float, ...] = (0.0, np.pi / 12, np.pi / 12, 0.0, 0.0, 0.0, 0.0)

#: Sleep (rest) pose (7 values): all joints 0, gripper closed.
SLEEP_POSE: tuple[float, ...] = (0.0,) * NUM_ARM_VALUES

#: Error states of the arm controller that a command causes (a goal past the joint limits,
#: a non-finite or malformed input), not the hardware: after one, :meth:`TrossenArmDriver.
#: recover` may clear the state so that the arm can be taken home. Names of
#: ``trossen_arm.ErrorState`` members.
COMMAND_ERRORS: frozenset[str] = frozenset(
    {
        "joint_limit_exceeded",
        "robot_input_infinite",
        "robot_input_mode_mismatch",
        "invalid_mode",
        "invalid_robot_command",
    }
)

#: Robot model and end-effector preset names understood by :meth:`ArmDriver.configure`.
DEFAULT_MODEL: str = "wxai_v0"
DEFAULT_END_EFFECTOR: str = "wxai_v0_follower"

#: Seconds ``configure`` waits for an arm controller: ``trossen_arm``'s default.
CONNECT_TIMEOUT_S: float = 20.0

INSTALL_HINT: str = (
    "pip install 'trossen-arm-mujoco[real]' (or use --backend sim for the simulated twin)"
)


@runtime_checkable
class ArmDriver(Protocol):
    """One arm, position-controlled. Mirrors the subset of ``trossen_arm`` replay uses."""

    def configure(
        self,
        ip_address: str,
        model: str = DEFAULT_MODEL,
        end_effector: str = DEFAULT_END_EFFECTOR,
        clear_error: bool = True,
    ) -> None:
        """Connect to the arm controller at ``ip_address`` and set it up.

        Args:
            ip_address: the arm controller's address (the simulated twin ignores it).
            model: robot model name, e.g. ``"wxai_v0"``.
            end_effector: end-effector preset name, e.g. ``"wxai_v0_follower"``.
            clear_error: clear a latched error state of the controller.
        """
        ...

    def set_all_modes_position(self) -> None:
        """Put every joint (and the gripper) in position mode."""
        ...

    def set_all_positions(
        self, positions: Sequence[float], goal_time: float, blocking: bool
    ) -> None:
        """Move toward ``positions`` (7 values: rad x6, gripper m), arriving after ``goal_time`` s.

        The controller interpolates its setpoint from where it is to the goal over
        ``goal_time``.

        Args:
            positions: 7 values: ``joint_0`` .. ``joint_5`` (rad), gripper (m).
            goal_time: seconds until the goal is reached.
            blocking: return only once ``goal_time`` has elapsed.
        """
        ...

    def get_all_positions(self) -> np.ndarray:
        """Measured positions: float64 ``(7,)``, rad x6 then gripper (m)."""
        ...

    def cleanup(self) -> None:
        """Release the arm (call after moving it to the sleep pose)."""
        ...


def split_arms(row: Sequence[float] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Map one 16-value dataset row to the two drivers' 7-value commands.

    Returns:
        ``(left, right)``, float64 ``(7,)`` each: ``row[0:7]`` and ``row[8:15]``
        (6 joints in rad, then the right-carriage finger travel in m).
    """
    row = np.asarray(row, dtype=np.float64)
    if row.shape != (VENDOR16_LAYOUT.size,):
        raise ValueError(f"expected {VENDOR16_LAYOUT.size} values, got shape {row.shape}")
    left, right = (row[VENDOR16_LAYOUT.driver_slice(side)].copy() for side in ("left", "right"))
    return left, right


def installed_version(package: str = "trossen_arm") -> str:
    """Installed version of ``package`` from its metadata, ``"unknown"`` when there is none.

    ``trossen_arm`` has no ``__version__``; pip's metadata is the only reliable source.
    """
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "unknown"


def find_trossen_arm() -> ModuleType | None:
    """The ``trossen_arm`` package if it can be imported, else None (no version check)."""
    try:
        import trossen_arm
    except ImportError:
        return None
    return trossen_arm


def import_trossen_arm() -> ModuleType:
    """Import the optional ``trossen_arm`` package, or raise a one-line install hint."""
    trossen_arm = find_trossen_arm()
    if trossen_arm is None:
        raise UserError(
            f"the trossen backend needs the 'trossen_arm' driver package, which is not "
            f"installed: {INSTALL_HINT}"
        )
    if not hasattr(trossen_arm, "TrossenArmDriver") or not hasattr(
        trossen_arm.TrossenArmDriver, "get_all_positions"
    ):
        raise UserError(
            f"trossen_arm {installed_version()} is too old (needs >= 1.9.1, with "
            "get_all_positions): pip install -U 'trossen-arm>=1.9.1'"
        )
    return trossen_arm


def route_driver_logs(ta: ModuleType, min_level: int = 3) -> None:
    """Send the ``trossen_arm`` driver's log messages of ``min_level`` and above (its
    ``LogLevel``: 3 = warn) to stdout, one line each (``trossen_arm <level>: <message>``),
    and drop the others.

    By default the driver writes every message, ``info`` included, to stderr over several
    lines; replay keeps stderr for its one-line error. The backend is process-wide (the
    driver has one); calling this again replaces it. It is released again before the
    interpreter exits (:func:`release_driver_logs`, registered with ``atexit``).
    """
    setter = getattr(getattr(ta, "TrossenArmDriver", None), "set_logger_backend", None)
    if setter is None:
        return

    def backend(level: Any, name: str, message: str) -> None:
        if int(level) < min_level:
            return
        label = getattr(level, "name", str(level))
        try:
            print(f"trossen_arm {label} ({name}): {' '.join(str(message).split())}", flush=True)
        except (OSError, ValueError):  # a closed stdout: nothing to report to
            pass

    _release_at_exit(ta)
    setter(backend)
    _LOG_STATE["routed"] = True


#: Process-wide state of the driver's log routing: whether a Python backend is installed
#: now, and whether its release at exit is registered.
_LOG_STATE: dict[str, bool] = {"routed": False, "atexit": False}

#: Every :class:`TrossenArmDriver` not yet cleaned up, released at exit before the backend.
_LIVE_DRIVERS: weakref.WeakSet[TrossenArmDriver] = weakref.WeakSet()


def _release_at_exit(ta: ModuleType) -> None:
    """Register :func:`release_driver_logs` with ``atexit`` (once per process)."""
    if not _LOG_STATE["atexit"]:
        atexit.register(release_driver_logs, ta)
        _LOG_STATE["atexit"] = True


def release_driver_logs(ta: ModuleType | None = None) -> None:
    """Clean up every :class:`TrossenArmDriver` still connected, then uninstall the Python
    log backend of :func:`route_driver_logs` (``set_logger_backend(None)``). Never raises.

    Why: ``trossen_arm`` keeps the backend, a Python callable, in a C++ static object that
    is destroyed by the C library's exit handlers, after the interpreter has finalized;
    destroying a Python object then needs a thread state (``PyThreadState_New``) that can
    no longer be made, and the process dies with SIGSEGV (exit status 139) after its last
    line, whatever it did before. Released while Python still runs, nothing is left for
    that destructor. Registered with ``atexit`` by :func:`route_driver_logs`; drivers go
    first, so that their last messages still reach the backend. Afterwards the driver's
    messages are dropped until :func:`route_driver_logs` is called again.
    """
    for driver in list(_LIVE_DRIVERS):
        try:
            driver.cleanup()
        except Exception:  # the process is ending: a failed cleanup changes nothing
            pass
    if not _LOG_STATE["routed"]:
        return
    ta = ta if ta is not None else find_trossen_arm()
    setter = getattr(getattr(ta, "TrossenArmDriver", None), "set_logger_backend", None)
    if setter is None:
        return
    try:
        setter(None)
    except Exception:
        return
    _LOG_STATE["routed"] = False


def end_effector_presets(ta: ModuleType) -> list[str]:
    """Names of the ``StandardEndEffector`` presets of the ``trossen_arm`` module ``ta``, sorted.

    Read by introspection, so they always match the installed package: every public,
    non-callable attribute (an ``EndEffector`` where the package defines that type).
    """
    cls = ta.StandardEndEffector
    kind = getattr(ta, "EndEffector", None)
    names = []
    for name in dir(cls):
        if name.startswith("_"):
            continue
        value = getattr(cls, name)
        if isinstance(kind, type) and not isinstance(value, kind):
            continue
        if not callable(value):
            names.append(name)
    return sorted(names)


def check_end_effector(ta: ModuleType, end_effector: str, flag: str | None = None) -> None:
    """Raise a one-line ``UserError`` listing the valid presets if ``end_effector`` is
    unknown.

    Args:
        ta: the imported ``trossen_arm`` module.
        end_effector: a ``trossen_arm.StandardEndEffector`` member name.
        flag: the command-line flag that chose it, named in the message.
    """
    valid = end_effector_presets(ta)
    if end_effector not in valid:
        where = f"StandardEndEffector presets of the installed trossen_arm {installed_version()}"
        if flag:
            where += f"; pass one of them with {flag}"
        raise unknown_name_error("end effector", end_effector, valid, where)


def resolve_presets(ta: ModuleType, model: str, end_effector: str) -> tuple[Any, Any]:
    """Look up ``trossen_arm.Model.<model>`` and ``trossen_arm.StandardEndEffector.<ee>``.

    Args:
        ta: the imported ``trossen_arm`` module.
        model: a ``trossen_arm.Model`` member name, e.g. ``"wxai_v0"``.
        end_effector: a ``trossen_arm.StandardEndEffector`` member name.

    Returns:
        (the model, the end-effector preset).

    Raises:
        UserError: an unknown name, listing the valid ones.
    """
    members = getattr(ta.Model, "__members__", None)
    models = list(members) if members else [n for n in dir(ta.Model) if not n.startswith("_")]
    if model not in models:
        raise unknown_name_error("robot model", model, models)
    check_end_effector(ta, end_effector)
    return getattr(ta.Model, model), getattr(ta.StandardEndEffector, end_effector)


class TrossenArmDriver:
    """:class:`ArmDriver` over a real arm, through ``trossen_arm.TrossenArmDriver``.

    Constructing it only imports the package (an install hint when it is missing) and
    routes the driver's warnings to stdout (:func:`route_driver_logs`); the network is
    first used by :meth:`configure`. Defaults configure the **follower**
    end-effector preset (``StandardEndEffector.wxai_v0_follower``), which matches the
    follower arms' fingers, unlike the vendor script's leader preset; in trossen_arm 1.11
    that is the 2026-06-26 hardware, and arms built in 2025 need
    ``wxai_v0_follower_20250509`` (see :func:`end_effector_presets`).

    Args:
        connect_timeout: seconds :meth:`configure` waits for the arm controller.
    """

    def __init__(self, connect_timeout: float = CONNECT_TIMEOUT_S) -> None:
        self._ta = import_trossen_arm()
        route_driver_logs(self._ta)
        self._driver: Any = None
        self.ip_address: str | None = None
        self.connect_timeout = float(connect_timeout)

    def configure(
        self,
        ip_address: str,
        model: str = DEFAULT_MODEL,
        end_effector: str = DEFAULT_END_EFFECTOR,
        clear_error: bool = True,
    ) -> None:
        """Connect to the controller at ``ip_address`` (see :meth:`ArmDriver.configure`),
        waiting at most ``connect_timeout`` s for it.

        A driver whose ``configure`` fails is cleaned up and released here, so that no
        half-made connection outlives the call.

        Args:
            ip_address: the arm controller's address.
            model: robot model name, e.g. ``"wxai_v0"``.
            end_effector: end-effector preset name, e.g. ``"wxai_v0_follower"``.
            clear_error: clear a latched error state of the controller.
        """
        model_enum, effector = resolve_presets(self._ta, model, end_effector)
        driver = self._ta.TrossenArmDriver()
        try:
            driver.configure(model_enum, effector, ip_address, clear_error, self.connect_timeout)
        except BaseException:
            try:
                driver.cleanup()
            except Exception:
                pass
            del driver  # the traceback keeps this frame: it must not keep the driver too
            raise
        self._driver, self.ip_address = driver, ip_address
        _LIVE_DRIVERS.add(self)

    def _configured(self) -> Any:
        if self._driver is None:
            raise RuntimeError("arm driver is not configured; call configure() first")
        return self._driver

    def set_all_modes_position(self) -> None:
        """``set_all_modes(Mode.position)``."""
        self._configured().set_all_modes(self._ta.Mode.position)

    def set_all_positions(
        self, positions: Sequence[float], goal_time: float, blocking: bool
    ) -> None:
        """Send 7 goal positions, reached after ``goal_time``.

        Args:
            positions: 7 values: ``joint_0`` .. ``joint_5`` (rad), gripper (m).
            goal_time: seconds until the goal is reached.
            blocking: return only once ``goal_time`` has elapsed.
        """
        values = [float(v) for v in positions]
        if len(values) != NUM_ARM_VALUES:
            raise ValueError(f"expected {NUM_ARM_VALUES} positions, got {len(values)}")
        self._configured().set_all_positions(values, float(goal_time), bool(blocking))

    def get_all_positions(self) -> np.ndarray:
        """Measured positions, float64 ``(7,)`` (rad x6, gripper m)."""
        return np.asarray(self._configured().get_all_positions(), dtype=np.float64)

    def error_state(self) -> tuple[str, str] | None:
        """The controller's error state: ``(ErrorState member name, one line of
        information)``, or None when there is none (or the driver is not configured).

        ``trossen_arm`` raises the error from most calls once the controller is in an error
        state, ``get_error_information`` included; the state is recognized by the text of
        ``trossen_arm.ERROR_INFORMATION``.
        """
        if self._driver is None:
            return None
        try:
            info = str(self._driver.get_error_information())
        except Exception as exc:  # the driver rethrows the controller's error
            info = str(exc)
        table = getattr(self._ta, "ERROR_INFORMATION", {})
        for state, text in table.items():
            name = getattr(state, "name", str(state))
            if name != "none" and text and text in info:
                return name, " ".join(info.split())
        return None

    def recover(self) -> str | None:
        """Clear an error state that a command caused (:data:`COMMAND_ERRORS`) and put the
        arm back in position mode, so that it can be taken home.

        Returns:
            None when the controller is not in an error state, else one line saying what
            was cleared.

        Raises:
            RuntimeError: the controller is in an error state of the hardware (overheated,
                CAN failure, ...), which is left alone: see the arm before clearing it.
        """
        found = self.error_state()
        if found is None:
            return None
        name, info = found
        if name not in COMMAND_ERRORS:
            raise RuntimeError(f"controller error state {name} not cleared: {info}")
        self._configured().clear_error()  # cleanup + configure(clear_error=True) inside
        self.set_all_modes_position()
        return f"cleared the controller's error state {name} ({info})"

    def cleanup(self) -> None:
        """Close the connection (idempotent)."""
        if self._driver is not None:
            driver, self._driver = self._driver, None
            _LIVE_DRIVERS.discard(self)
            driver.cleanup()
