"""Any exception from any driver call: every configured arm still ends homed, asleep, cleaned up.

A fake arm raises a non-driver exception (ValueError, TypeError, AssertionError like the
vendor's ``LogicError``) at one of its calls, in turn for every call a clean replay makes,
on either arm; or returns a wrong-length position vector at one of its reads. The replay
runs through the command line (``replay_episode_real.cli`` with a fake driver factory), so
the exit status and stderr are checked too: non-zero, one line, no traceback.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.real import report
from trossen_arm_mujoco.real.clock import Clock, SimClock
from trossen_arm_mujoco.real.driver import HOME_POSE, SLEEP_POSE
from trossen_arm_mujoco.real.replay import ReplayConfig, replay
from trossen_arm_mujoco.real.shutdown import move_time
from trossen_arm_mujoco.real.validate import ArmLimits, safe_move_time, validate_actions
from trossen_arm_mujoco.scripts import replay_episode_real

STEPS = 3
ARMS = ("left", "right")

#: The calls a clean replay of STEPS steps makes on each arm, in order.
CALLS: tuple[str, ...] = (
    "configure",
    "set_all_modes_position",
    "get_all_positions",  # start move: where the arm is
    "set_all_positions",  # start move
    *("set_all_positions", "get_all_positions") * STEPS,  # stream: command, measure
    "get_all_positions",  # home move: where the arm is
    "set_all_positions",  # home
    "get_all_positions",  # sleep move: where the arm is
    "set_all_positions",  # sleep
    "get_all_positions",  # final positions
    "cleanup",
)
READS = [n for n, name in enumerate(CALLS, start=1) if name == "get_all_positions"]


class FakeArm:
    """A strict in-memory arm: commands need configure and position mode; moves are instant.

    ``fail_at`` (1-based call number) injects ``fault`` once: an exception type to raise,
    or ``"bad_read"``: ``get_all_positions`` returns 6 values instead of 7.
    """

    def __init__(self, fail_at: int | None = None, fault: Any = ValueError) -> None:
        self.fail_at, self.fault = fail_at, fault
        self.calls: list[str] = []
        self.sent: list[np.ndarray] = []
        self.pos = np.zeros(7)
        self.configured = self.position_mode = self.cleaned = self.was_configured = False
        self.end_effector: str | None = None

    def _enter(self, name: str) -> bool:
        self.calls.append(name)
        hit = len(self.calls) == self.fail_at
        if hit and self.fault != "bad_read":
            raise self.fault(f"injected fault in {name}")
        return hit

    def configure(self, ip_address: str, model: str, end_effector: str, clear_error: bool) -> None:
        self._enter("configure")
        self.configured = self.was_configured = True
        self.end_effector = end_effector

    def set_all_modes_position(self) -> None:
        self._enter("set_all_modes_position")
        if not self.configured:
            raise RuntimeError("not configured")
        self.position_mode = True

    def set_all_positions(self, positions: Any, goal_time: float, blocking: bool) -> None:
        self._enter("set_all_positions")
        if not (self.configured and self.position_mode):
            raise RuntimeError("not configured or not in position mode")
        goal = np.asarray(positions, dtype=np.float64)
        assert goal.shape == (7,) and goal_time > 0
        self.pos = goal.copy()
        self.sent.append(goal.copy())

    def get_all_positions(self) -> np.ndarray:
        bad = self._enter("get_all_positions")
        return self.pos[:6].copy() if bad else self.pos.copy()

    def cleanup(self) -> None:
        self._enter("cleanup")
        self.configured = self.position_mode = False
        self.cleaned = True


class Factory:
    """Driver factory for the CLI: two fake arms on a simulated clock."""

    def __init__(self, **arms: FakeArm) -> None:
        self.drivers = {side: arms.get(side, FakeArm()) for side in ARMS}

    def __call__(self, backend: str, clock: Clock | None) -> tuple[dict[str, Any], Clock]:
        return self.drivers, SimClock()


def assert_safe(arm: FakeArm) -> None:
    """A configured arm was sent home, then to sleep (last), and cleaned up."""
    if not arm.was_configured:
        assert arm.sent == []  # never configured: never commanded
        return
    assert len(arm.sent) >= 2, arm.calls
    np.testing.assert_allclose(arm.sent[-2], HOME_POSE)
    np.testing.assert_allclose(arm.sent[-1], SLEEP_POSE)
    assert arm.cleaned and not arm.configured and arm.calls[-1] == "cleanup"


@pytest.fixture(autouse=True)
def no_plot(monkeypatch: pytest.MonkeyPatch) -> None:
    """Skip the PNG (about 1 s each): as if matplotlib were missing."""

    def missing(*args: Any, **kwargs: Any) -> None:
        raise ImportError("matplotlib")

    monkeypatch.setattr(report, "plot_tracking", missing)


@pytest.fixture
def episode(tmp_path: Path, smooth) -> Path:
    actions = smooth(STEPS)
    with h5py.File(tmp_path / "episode_0.hdf5", "w") as f:
        f.attrs["sim"] = True
        f.create_dataset("observations/qpos", data=actions)
        f.create_dataset("observations/qvel", data=np.zeros_like(actions))
        f.create_dataset("action", data=actions)
    return tmp_path


def run_cli(folder: Path, factory: Factory, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    argv = ["--data_dir", str(folder), "--backend", "sim", "--no_progress"]
    rc = replay_episode_real.cli(argv, driver_factory=factory)
    return rc, capsys.readouterr().err


def test_clean_run_makes_exactly_the_listed_calls(
    episode: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    factory = Factory()
    rc, err = run_cli(episode, factory, capsys)
    assert rc == 0 and err == ""
    for arm in factory.drivers.values():
        assert tuple(arm.calls) == CALLS  # the fault tests below cover every one of them
        assert_safe(arm)


FAULTS = [
    pytest.param(side, n, exc, id=f"{side}-{n}-{CALLS[n - 1]}-{exc.__name__}")
    for exc in (ValueError, TypeError, AssertionError)
    for side in ARMS
    for n in range(1, len(CALLS) + 1)
]


@pytest.mark.parametrize(("side", "fail_at", "exc"), FAULTS)
def test_exception_at_any_call_still_homes_sleeps_and_cleans_up(
    side: str, fail_at: int, exc: type[Exception], episode: Path, capsys
) -> None:
    factory = Factory(**{side: FakeArm(fail_at, exc)})
    rc, err = run_cli(episode, factory, capsys)
    for arm in factory.drivers.values():
        assert_safe(arm)
    assert rc == 1
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    name = CALLS[fail_at - 1]
    assert f"{side} arm: {name}" in lines[0]
    assert f"{exc.__name__}: injected fault in {name}" in lines[0]
    if CALLS[fail_at - 1] == "configure" and side == "left":
        assert factory.drivers["right"].calls == []  # never reached


@pytest.mark.parametrize("side", ARMS)
@pytest.mark.parametrize("fail_at", READS)
def test_wrong_length_read_is_a_one_line_error_and_arms_still_sleep(
    side: str, fail_at: int, episode: Path, capsys
) -> None:
    factory = Factory(**{side: FakeArm(fail_at, "bad_read")})
    rc, err = run_cli(episode, factory, capsys)
    for arm in factory.drivers.values():
        assert_safe(arm)
    lines = err.strip().splitlines()
    assert rc == 1 and len(lines) == 1 and "Traceback" not in err
    assert f"{side} arm: get_all_positions failed: ValueError: returned shape (6,)" in lines[0]


class DeadReads(FakeArm):
    """Every read fails from call ``from_call`` on (a controller that stopped answering)."""

    def __init__(self, from_call: int) -> None:
        super().__init__()
        self.from_call = from_call
        self.goal_times: list[float] = []

    def get_all_positions(self) -> np.ndarray:
        self.calls.append("get_all_positions")
        if len(self.calls) >= self.from_call:
            raise TypeError("positions unavailable")
        return self.pos.copy()

    def set_all_positions(self, positions: Any, goal_time: float, blocking: bool) -> None:
        self.goal_times.append(goal_time)
        super().set_all_positions(positions, goal_time, blocking)


def test_unreadable_arm_is_still_sent_home_and_to_sleep_at_a_safe_pace(smooth) -> None:
    traj = validate_actions(smooth(STEPS), 10.0)
    dead, ok = DeadReads(from_call=6), FakeArm()  # first streamed read fails, and all after
    clock = SimClock()
    result = replay(traj, {"left": dead, "right": ok}, clock, ReplayConfig(progress=False))
    for arm in (dead, ok):
        assert_safe(arm)
    assert result.exit_code == 1 and "left" not in result.final_positions
    assert "left arm: get_all_positions failed: TypeError: positions unavailable" in result.reason
    assert "(failed 2 times)" in result.reason
    # position unknown: the home and sleep moves take the worst case over the joint ranges
    limits = ArmLimits.from_mjcf()
    expected = [move_time(None, np.asarray(p), 2.0, limits) for p in (HOME_POSE, SLEEP_POSE)]
    assert dead.goal_times[-2:] == expected


@pytest.mark.parametrize("goal", [HOME_POSE, SLEEP_POSE])
def test_move_time_of_an_unknown_start_covers_every_start(goal) -> None:
    limits, goal = ArmLimits.from_mjcf(), np.asarray(goal)
    starts = np.random.default_rng(0).uniform(limits.driver_lower, limits.driver_upper, (500, 7))
    starts = np.vstack([starts, limits.driver_lower, limits.driver_upper])
    worst = move_time(None, goal, 0.0, limits)
    assert worst >= max(safe_move_time(s, goal, 0.0, limits) for s in starts) > 0.5


def test_keyboard_interrupt_from_a_driver_during_shutdown_spares_the_other_arm(smooth) -> None:
    class CtrlC(FakeArm):
        def cleanup(self) -> None:
            self.calls.append("cleanup")
            raise KeyboardInterrupt

    traj = validate_actions(smooth(STEPS), 10.0)
    left, right = CtrlC(), FakeArm()
    result = replay(traj, {"left": left, "right": right}, SimClock(), ReplayConfig(progress=False))
    assert_safe(right)
    np.testing.assert_allclose(left.sent[-1], SLEEP_POSE)
    assert left.calls[-2:] == ["cleanup", "cleanup"]  # tried twice
    assert result.exit_code == 1 and "left arm: cleanup failed: KeyboardInterrupt" in result.reason
