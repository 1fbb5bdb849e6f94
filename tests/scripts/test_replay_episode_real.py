"""replay_episode_real: validation before motion, sim-twin replay, safe exit, outputs.

The sim backend, and the wire backend (the real ``trossen_arm`` driver against the
simulated kit served on 127.0.0.81 / 127.0.0.82). Two local guards (the same as
tests/real/conftest.py) fail a test that opens a non-loopback connection or configures a
real arm.
"""

from __future__ import annotations

import importlib.metadata
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco import cli as top_cli
from trossen_arm_mujoco.constants import START_ARM_POSE
from trossen_arm_mujoco.real import driver as driver_module
from trossen_arm_mujoco.real.clock import Clock, SimClock
from trossen_arm_mujoco.real.replay import make_drivers
from trossen_arm_mujoco.real.sim_driver import SimArmDriver
from trossen_arm_mujoco.scripts import replay_episode_real

REPO = Path(__file__).resolve().parents[2]
VENDOR_600 = REPO / "tests" / "fixtures" / "vendor_transfer_cube_600steps_noimages.hdf5"
SCRIPT = REPO / "trossen_arm_mujoco" / "scripts" / "replay_episode_real.py"


@pytest.fixture(autouse=True)
def offline(monkeypatch: pytest.MonkeyPatch) -> None:
    """Fail on non-loopback connections and on configuring a real arm (any address outside
    127.0.0.0/8; there, only the served kit of ``--backend wire`` answers)."""

    def loopback(address: Any) -> bool:
        if isinstance(address, (str, bytes)):
            return True
        host = str(address[0])
        return host in ("localhost", "::1") or host.startswith("127.")

    def guard(real):
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            address = args[1] if real is not socket.create_connection else args[0]
            if not loopback(address):
                pytest.fail(f"test tried to connect to {address!r}")
            return real(*args, **kwargs)

        return wrapper

    monkeypatch.setattr(socket.socket, "connect", guard(socket.socket.connect))
    monkeypatch.setattr(socket.socket, "connect_ex", guard(socket.socket.connect_ex))
    monkeypatch.setattr(socket, "create_connection", guard(socket.create_connection))

    real = driver_module.TrossenArmDriver.configure

    def refuse(self: Any, ip_address: str, *args: Any, **kwargs: Any) -> None:
        if not str(ip_address).startswith("127."):  # loopback: the served kit (--backend wire)
            pytest.fail(f"test tried to configure a real arm at {ip_address!r}")
        return real(self, ip_address, *args, **kwargs)

    monkeypatch.setattr(driver_module.TrossenArmDriver, "configure", refuse)


class Spy:
    """Driver factory that builds the sim twin and remembers what it built."""

    def __init__(self) -> None:
        self.calls: list[str] = []
        self.drivers: dict[str, Any] = {}

    def __call__(self, backend: str, clock: Clock | None) -> tuple[dict[str, Any], Clock]:
        self.calls.append(backend)
        self.drivers, clock = make_drivers("sim", clock)
        return self.drivers, clock


class SignalClock(SimClock):
    """Sends ``signum`` to this process once simulated time reaches ``at`` seconds."""

    def __init__(self, at: float, signum: int = signal.SIGINT) -> None:
        super().__init__()
        self.at, self.signum, self.sent = at, signum, False

    def sleep(self, seconds: float) -> None:
        super().sleep(seconds)
        if not self.sent and self.now() >= self.at:
            self.sent = True
            os.kill(os.getpid(), self.signum)


def smooth_actions(num_steps: int = 20) -> np.ndarray:
    """Smooth (T, 16) motion from START_ARM_POSE, well within limits at 10 fps."""
    s = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, num_steps))
    out = np.tile(np.asarray(START_ARM_POSE, dtype=np.float64), (num_steps, 1))
    for off, sign in ((0, 1.0), (8, -1.0)):
        out[:, off : off + 6] += np.array([0.3 * sign, 0.3, 0.3, 0.2, 0.2 * sign, 0.3]) * s[:, None]
        out[:, off + 6] = out[:, off + 7] = 0.044 - 0.014 * s
    return out


def write_episode(
    folder: Path, action: np.ndarray, idx: int = 0, qpos: np.ndarray | None = None
) -> Path:
    """This project's layout, written with plain h5py (float64, root attr sim=True).

    ``qpos`` defaults to ``action``.
    """
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"episode_{idx}.hdf5"
    qpos = np.asarray(action if qpos is None else qpos, dtype=np.float64)
    with h5py.File(path, "w") as f:
        f.attrs["sim"] = True
        f.create_dataset("observations/qpos", data=qpos)
        f.create_dataset("observations/qvel", data=np.zeros_like(qpos))
        f.create_dataset("action", data=np.asarray(action, dtype=np.float64))
    return path


def run(argv: list[str], **kwargs: Any) -> int:
    return replay_episode_real.cli([*argv, "--no_progress"], **kwargs)


def one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


def test_vendor_episode_full_replay_on_the_sim_twin(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = tmp_path / "vendor"
    folder.mkdir()
    shutil.copyfile(VENDOR_600, folder / "episode_0.hdf5")
    spy = Spy()
    rc = run(["--data_dir", str(folder), "--backend", "sim"], driver_factory=spy)
    out = capsys.readouterr().out
    assert rc == 0, out
    assert spy.calls == ["sim"]
    assert "tracking error (measured - commanded) over 600 steps" in out
    print(out)  # the table, for the record (pytest -s)

    stem = folder / "replay" / "episode_0_sim"
    summary = json.loads(Path(f"{stem}_summary.json").read_text())
    assert summary["status"] == "completed" and summary["steps_done"] == 600
    # gripper commands (index 6 and 14) above the controller's 0.04 m: clamped and counted
    with h5py.File(VENDOR_600) as f:
        grippers = f["action"][:, [6, 14]]
    above = int(np.count_nonzero(grippers > 0.04))
    assert 0 < above < grippers.size == summary["gripper_commands"] == 1200
    assert summary["gripper_clamped"] == above and summary["gripper_max_m"] == 0.04
    assert summary["gripper_clamped_per_arm"] == {
        "left": int(np.count_nonzero(grippers[:, 0] > 0.04)),
        "right": int(np.count_nonzero(grippers[:, 1] > 0.04)),
    }
    assert summary["gripper_max_excess_m"] == pytest.approx(grippers.max() - 0.04, abs=1e-6)
    assert f"gripper commands above --gripper_max 0.04 m: {above} of 1200 clamped" in out
    assert f"replay completed: 600 steps, {above} gripper command(s) clamped to 0.04 m" in out
    with open(f"{stem}_tracking.csv") as f:
        header, *rows = [line.split(",") for line in f.read().splitlines()]
    for arm in ("left", "right"):
        sent = np.array([float(r[header.index(f"cmd_{arm}_gripper")]) for r in rows])
        assert sent.max() == pytest.approx(0.04)  # what was sent, after clamping
    assert summary["end_effector"] == "wxai_v0_follower"
    assert summary["fps"] == 10.0 and summary["goal_time_s"] == pytest.approx(0.3)
    assert Path(f"{stem}_tracking.png").stat().st_size > 10_000
    assert len(Path(f"{stem}_tracking.csv").read_text().splitlines()) == 601
    # Measured on the twin (goal time 3/fps = 0.3 s, measured at the end of each period):
    # RMS <= 23 mrad / 1.3 mm, max <= 143 mrad / 14 mm (at the start, where the recording
    # snaps from START_ARM_POSE to the mocap pose). Bounds leave ~50% headroom.
    for label, e in summary["tracking_error"].items():
        assert np.isfinite(e["rms"]) and np.isfinite(e["max"]), label
        rms_bound, max_bound = (0.002, 0.02) if e["unit"] == "m" else (0.035, 0.2)
        assert e["rms"] < rms_bound and e["max"] < max_bound, (label, e)
    for side, final in summary["final_positions"].items():
        np.testing.assert_allclose(final[:6], 0.0, atol=0.01, err_msg=side)


def test_short_project_episode_replays(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_episode(tmp_path / "mine", smooth_actions(20), idx=3)
    spy = Spy()
    argv = ["--root_dir", str(tmp_path), "--data_dir", "mine", "--episode_idx", "3"]
    rc = run([*argv, "--backend", "sim", "--fps", "20"], driver_factory=spy)
    out = capsys.readouterr().out
    assert rc == 0 and "replay completed: 20 steps" in out
    summary = json.loads((tmp_path / "mine/replay/episode_3_sim_summary.json").read_text())
    assert summary["steps_done"] == 20 and summary["goal_time_s"] == pytest.approx(0.15)
    assert summary["tracking_error"]["left_joint_1"]["max"] < 0.1  # measured 0.069 rad
    for drv in spy.drivers.values():
        np.testing.assert_allclose(drv.get_all_positions()[:6], 0.0, atol=0.01)


def _bad(kind: str) -> np.ndarray:
    actions = smooth_actions(20)
    if kind == "nan":
        actions[4, 11] = np.nan
    elif kind == "shape":
        actions = actions[:, :14]
    elif kind == "limit":
        actions[6, 9] = 3.5  # right joint_1, limit 3.14159
    elif kind == "fast":
        actions[12:, 3] += 1.0  # left joint_3 jumps 1 rad
    return actions


@pytest.mark.parametrize(
    ("kind", "expected"),
    [
        ("nan", "/action contains NaN or inf (first at step 4)"),  # caught by the reader
        ("shape", "/action has shape (20, 14), expected (T, 16)"),  # caught by the reader
        ("limit", "step 6, right arm, joint_1: 3.5 rad is outside the joint limits"),
        ("fast", "step 11 -> 12, left arm, joint_3: speed 10.16 rad/s exceeds the limit 7 rad/s"),
    ],
)
def test_invalid_trajectory_exits_2_before_any_driver(
    kind: str, expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path, _bad(kind), qpos=smooth_actions(20))
    spy = Spy()
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim"], driver_factory=spy)
    assert rc == 2
    assert expected in one_line_error(capsys)
    assert spy.calls == [] and not (tmp_path / "replay").exists()  # nothing built, nothing moved


def test_vendor_episode_at_50_fps_is_too_fast(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    shutil.copyfile(VENDOR_600, tmp_path / "episode_0.hdf5")
    spy = Spy()
    rc = run(["--data_dir", str(tmp_path), "--fps", "50", "--backend", "sim"], driver_factory=spy)
    line = one_line_error(capsys)
    assert rc == 2 and spy.calls == []
    assert "step 0 -> 1, left arm, joint_1" in line and "--fps 10.1 or lower" in line


def test_dry_run_moves_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copyfile(VENDOR_600, tmp_path / "episode_0.hdf5")
    spy = Spy()
    rc = run(["--data_dir", str(tmp_path), "--dry_run"], driver_factory=spy)  # trossen default
    out = capsys.readouterr().out
    assert rc == 0 and spy.calls == []
    assert "600 steps, 60.0 s at --fps 10 (0.2x the recorded speed" in out
    assert "highest valid --fps: 10.1" in out and "no driver was created" in out
    assert not (tmp_path / "replay").exists()


def test_trossen_backend_without_package_gives_install_hint(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "trossen_arm", None)  # not importable, even if installed
    write_episode(tmp_path, smooth_actions(5))
    rc = run(["--data_dir", str(tmp_path)])  # default backend: trossen
    line = one_line_error(capsys)
    assert rc == 2
    assert "pip install 'trossen-arm-mujoco[real]'" in line and "--backend sim" in line


def test_sigint_mid_stream_returns_home_then_sleep(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path, smooth_actions(60))
    spy = Spy()
    clock = SignalClock(at=2.5 + 2.0)  # 2 s into streaming at 10 fps
    previous = signal.getsignal(signal.SIGINT)
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim"], driver_factory=spy, clock=clock)
    err = capsys.readouterr().err
    assert rc == 130 and clock.sent
    assert "Traceback" not in err
    last = err.strip().splitlines()[-1]
    assert last.startswith("error: replay stopped at step ") and "interrupted by SIGINT" in last
    for drv in spy.drivers.values():
        np.testing.assert_allclose(drv.get_all_positions()[:6], 0.0, atol=0.01)
        assert not drv.configured
    summary = json.loads((tmp_path / "replay/episode_0_sim_summary.json").read_text())
    assert summary["status"] == "interrupted" and 10 <= summary["steps_done"] < 60
    assert signal.getsignal(signal.SIGINT) is previous


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--fps", "0"], "--fps must be in [0.5, 1000] Hz, got 0: one command lasts 1/fps"),
        (["--fps", "nan"], "--fps must be in [0.5, 1000] Hz, got nan"),
        (["--fps", "1001"], "--fps must be in [0.5, 1000] Hz, got 1001"),
        (["--goal_time_factor", "-1"], "--goal_time_factor must be in (0, 20]"),
        (["--episode_idx", "7"], "episode file not found"),
        (["--gripper_max", "0"], "--gripper_max must be in (0, 0.044] m, got 0"),
        (["--gripper_max", "0.05"], "--gripper_max must be in (0, 0.044] m, got 0.05"),
        (["--gripper_max", "nan"], "--gripper_max must be in (0, 0.044] m"),
    ],
)
def test_bad_flags_are_one_line_errors(
    argv: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path, smooth_actions(5))
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim", *argv], driver_factory=Spy())
    assert rc == 2 and expected in one_line_error(capsys)


def test_gripper_max_sets_the_clamp_and_dry_run_reports_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    actions = smooth_actions(20)  # grippers close from 0.044 to 0.030 m
    write_episode(tmp_path, actions)
    rc = run(["--data_dir", str(tmp_path), "--dry_run", "--gripper_max", "0.035"])
    out = capsys.readouterr().out
    above = int(np.count_nonzero(actions[:, [6, 14]] > 0.035))
    assert rc == 0 and 0 < above < 40
    assert f"gripper commands above --gripper_max 0.035 m: {above} of 40 clamped" in out


class PresetSpy(SimArmDriver):
    """The twin, recording the end-effector preset it was configured with."""

    presets: list[str] = []

    def configure(self, ip_address: str, model: str, end_effector: str, clear_error: bool) -> None:
        PresetSpy.presets.append(end_effector)
        super().configure(ip_address, model, "wxai_v0_follower", clear_error)


def preset_spy(backend: str, clock: Clock | None) -> tuple[dict[str, Any], Clock]:
    clock = SimClock()
    return {side: PresetSpy(clock) for side in ("left", "right")}, clock


def test_end_effector_preset_reaches_configure(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    ta = pytest.importorskip("trossen_arm")
    preset = "wxai_v0_follower_20250509"  # arms of 2025, in trossen_arm >= 1.11
    if not hasattr(ta.StandardEndEffector, preset):
        pytest.skip(f"trossen_arm {importlib.metadata.version('trossen_arm')} has no {preset}")
    monkeypatch.setattr(PresetSpy, "presets", [])
    write_episode(tmp_path, smooth_actions(5))
    rc = run(["--data_dir", str(tmp_path), "--end_effector", preset], driver_factory=preset_spy)
    assert rc == 0, capsys.readouterr().err
    assert PresetSpy.presets == [preset, preset]  # backend trossen: sent to both arms
    summary = json.loads((tmp_path / "replay/episode_0_trossen_summary.json").read_text())
    assert summary["end_effector"] == preset
    assert summary["trossen_arm_version"] == importlib.metadata.version("trossen_arm")
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim", "--end_effector", preset])
    out = capsys.readouterr().out
    assert rc == 0 and f"note: --end_effector {preset} is valid; the twin models" in out


@pytest.mark.parametrize("backend", ["trossen", "sim"])
def test_unknown_end_effector_lists_the_installed_presets(
    backend: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ta = pytest.importorskip("trossen_arm")
    valid = sorted(
        n
        for n in dir(ta.StandardEndEffector)
        if isinstance(getattr(ta.StandardEndEffector, n), ta.EndEffector)
    )
    write_episode(tmp_path, smooth_actions(5))
    spy = Spy()
    argv = ["--data_dir", str(tmp_path), "--backend", backend, "--end_effector", "wxai_v9"]
    rc = run(argv, driver_factory=spy)
    line = one_line_error(capsys)
    assert rc == 2 and spy.calls == [] and not (tmp_path / "replay").exists()
    assert line == (
        f"error: unknown end effector 'wxai_v9'; valid end effectors: {', '.join(valid)} "
        f"(StandardEndEffector presets of the installed trossen_arm "
        f"{importlib.metadata.version('trossen_arm')})"
    )


def test_sim_backend_without_trossen_arm_accepts_the_preset_with_a_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "trossen_arm", None)  # not importable, even if installed
    write_episode(tmp_path, smooth_actions(5))
    argv = ["--data_dir", str(tmp_path), "--backend", "sim", "--end_effector", "anything"]
    rc = run(argv, driver_factory=Spy())
    out = capsys.readouterr().out
    assert rc == 0 and "replay completed: 5 steps" in out
    assert "note: trossen_arm is not installed, so --end_effector anything is not checked" in out
    summary = json.loads((tmp_path / "replay/episode_0_sim_summary.json").read_text())
    assert summary["end_effector"] == "anything" and summary["trossen_arm_version"] is None


def test_trossen_mujoco_replay_real_dispatch(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path, smooth_actions(5))
    assert top_cli.main(["replay-real", "--data_dir", str(tmp_path), "--dry_run"]) == 0
    assert "dry run: trajectory is valid" in capsys.readouterr().out


def test_runs_as_a_file_on_the_sim_twin(tmp_path: Path) -> None:
    write_episode(tmp_path, smooth_actions(10))
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--data_dir", str(tmp_path), "--backend", "sim"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    assert "replay completed: 10 steps" in proc.stdout
    assert (tmp_path / "replay" / "episode_0_sim_tracking.csv").exists()


# --- rate bounds, episode dt, --help, and stopping by signal at any moment -----------------


@pytest.fixture
def leak_guard() -> Any:
    """While a test runs, SIGTERM/SIGHUP/SIGQUIT raise here instead of killing pytest.

    The replay saves and restores these handlers; a signal it failed to catch ends the
    test with ``RuntimeError: signal leaked`` rather than the whole session.
    """

    def leaked(signum: int, _frame: Any) -> None:
        raise RuntimeError(f"signal leaked: {signal.Signals(signum).name}")

    sigs = (signal.SIGTERM, signal.SIGHUP, signal.SIGQUIT)
    previous = {s: signal.signal(s, leaked) for s in sigs}
    yield leaked
    for s, old in previous.items():
        signal.signal(s, old)


def no_matplotlib(*args: Any, **kwargs: Any) -> None:
    raise ImportError("matplotlib")


def temp_files(folder: Path) -> list[Path]:
    return sorted(folder.rglob("*.tmp"))


def test_fps_below_the_lower_bound_is_one_line_with_the_bound_and_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path, smooth_actions(5))
    spy = Spy()
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim", "--fps", "1e-9"], driver_factory=spy)
    assert rc == 2 and spy.calls == []
    assert one_line_error(capsys) == (
        "error: --fps must be in [0.5, 1000] Hz, got 1e-09: one command would last 1e+09 s; "
        "one command lasts 1/fps, which must be between 1 ms and 2 s, the goal time "
        "trossen_arm gives a whole move by default (as do this replay's start and home moves)"
    )
    assert run(["--data_dir", str(tmp_path), "--fps", "0.49", "--dry_run"]) == 2
    assert "got 0.49: one command would last 2.04 s" in one_line_error(capsys)
    assert run(["--data_dir", str(tmp_path), "--fps", "0.5", "--dry_run"]) == 0  # the bound


def test_fps_bound_through_the_subprocess_exits_2_with_one_line(tmp_path: Path) -> None:
    write_episode(tmp_path, smooth_actions(5))
    argv = ["replay-real", "--data_dir", str(tmp_path), "--backend", "sim", "--fps", "1e-9"]
    proc = subprocess.run(
        [sys.executable, "-m", "trossen_arm_mujoco.cli", *argv],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    assert proc.returncode == 2 and proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: --fps must be in [0.5, 1000] Hz")


@pytest.mark.parametrize("dt", [0.0, -0.02, float("nan"), float("inf")])
@pytest.mark.parametrize("dry_run", [True, False])
def test_bad_dt_attribute_is_one_line_naming_file_and_attribute(
    dt: float, dry_run: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_episode(tmp_path, smooth_actions(5))
    with h5py.File(path, "a") as f:
        f.attrs["dt"] = dt
    spy = Spy()
    argv = ["--data_dir", str(tmp_path), "--backend", "sim", *(["--dry_run"] * dry_run)]
    rc = run(argv, driver_factory=spy)
    line = one_line_error(capsys)
    assert rc == 2 and spy.calls == [] and not (tmp_path / "replay").exists()
    assert line.startswith(f"error: {path}: attribute 'dt' is {dt!r}; expected the step period")


def test_help_names_the_trossen_mujoco_subcommand(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        top_cli.main(["replay-real", "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and out.startswith("usage: trossen-mujoco replay-real ")
    assert "[0.5, 1000]" in out and "--realtime" in out


def _signal_during_factory(signum: int) -> Any:
    def factory(backend: str, clock: Clock | None) -> tuple[dict[str, Any], Clock]:
        drivers, clock = make_drivers("sim", clock)
        factory.drivers = drivers  # type: ignore[attr-defined]
        os.kill(os.getpid(), signum)  # handled before this returns: nothing may move yet
        return drivers, clock

    return factory


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_before_any_arm_is_configured_ends_at_once(
    signum: int, tmp_path: Path, capsys: pytest.CaptureFixture[str], leak_guard: Any
) -> None:
    write_episode(tmp_path, smooth_actions(5))
    factory = _signal_during_factory(signum)
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim"], driver_factory=factory)
    name = signal.Signals(signum).name
    assert rc == 128 + signum
    assert one_line_error(capsys) == (
        f"error: interrupted by {name} before any arm was configured; nothing moved"
    )
    assert not any(d.configured for d in factory.drivers.values())
    assert list((tmp_path / "replay").iterdir()) == []  # nothing written, no temp file
    assert signal.getsignal(signal.SIGTERM) is leak_guard


def test_signal_during_homing_is_noted_and_the_replay_still_completes(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    leak_guard: Any,
) -> None:
    from trossen_arm_mujoco.real import report

    monkeypatch.setattr(report, "plot_tracking", no_matplotlib)  # the PNG takes ~1 s
    write_episode(tmp_path, smooth_actions(5))
    clock = SignalClock(at=2.5 + 0.5 + 1.0, signum=signal.SIGTERM)  # 1 s into the home move
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim"], driver_factory=Spy(), clock=clock)
    out, err = capsys.readouterr()
    assert clock.sent and rc == 0 and err == ""
    assert "note: SIGTERM arrived after streaming had ended; noted and ignored" in out
    assert out.strip().splitlines()[-1].endswith("arms are home and asleep")
    summary = json.loads((tmp_path / "replay/episode_0_sim_summary.json").read_text())
    assert summary["status"] == "completed" and summary["late_signals"] == ["SIGTERM"]
    assert summary["arms_home_and_asleep"] is True and summary["steps_done"] == 5
    assert temp_files(tmp_path) == []


@pytest.mark.parametrize("target", ["csv", "summary"])
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_while_the_results_are_written_leaves_them_complete(
    target: str,
    signum: int,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    leak_guard: Any,
) -> None:
    from trossen_arm_mujoco.real import report

    real_write = report.write_text
    sent: list[Path] = []

    def write_with_a_signal(path: Path, text: str, **kwargs: Any) -> Path:
        if Path(path).name.endswith(f"_{'tracking.csv' if target == 'csv' else 'summary.json'}"):
            with report.atomic_path(path) as tmp:  # the signal lands mid-write
                tmp.write_text(text[: len(text) // 2])
                os.kill(os.getpid(), signum)
                sent.append(tmp)
                with open(tmp, "a") as f:
                    f.write(text[len(text) // 2 :])
            return Path(path)
        return real_write(path, text, **kwargs)

    monkeypatch.setattr(report, "write_text", write_with_a_signal)
    monkeypatch.setattr(report, "plot_tracking", no_matplotlib)  # the PNG takes ~1 s
    write_episode(tmp_path, smooth_actions(8))
    rc = run(["--data_dir", str(tmp_path), "--backend", "sim"], driver_factory=Spy())
    out, err = capsys.readouterr()
    name = signal.Signals(signum).name
    assert sent and rc == 0 and err == "", err
    assert f"note: {name} arrived after streaming had ended" in out
    last = out.strip().splitlines()[-1]
    assert last.startswith("replay completed: 8 steps, ")
    assert last.endswith("; arms are home and asleep")
    folder = tmp_path / "replay"
    summary = json.loads((folder / "episode_0_sim_summary.json").read_text())
    assert summary["status"] == "completed" and summary["steps_done"] == 8
    assert set(summary["tracking_error"]) >= {"left_joint_0", "right_gripper"}
    assert len((folder / "episode_0_sim_tracking.csv").read_text().splitlines()) == 9
    assert temp_files(tmp_path) == []


def _read_lines(stream: Any, sink: list[tuple[float, str]]) -> None:
    for line in stream:
        sink.append((time.monotonic(), line.rstrip("\n")))


def _wait_for(lines: list[tuple[float, str]], text: str, timeout: float) -> float | None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        for t, line in list(lines):
            if text in line:
                return t
        time.sleep(0.02)
    return None


def test_real_sigint_and_sigterm_stop_a_slow_replay_mid_command(tmp_path: Path) -> None:
    """Two ``trossen-mujoco replay-real`` processes on the twin paced to real time at
    --fps 0.5 (2 s per command), one sent SIGINT and one SIGTERM in the middle of a
    command period: each stops within 2 s, homes, writes the summary, says the arms are
    home and exits with 128 + the signal's number. Both run at once, to keep this short.
    """
    runs = {}
    for signum in (signal.SIGINT, signal.SIGTERM):
        folder = tmp_path / signal.Signals(signum).name
        write_episode(folder, smooth_actions(10))
        argv = ["replay-real", "--data_dir", str(folder), "--backend", "sim", "--realtime"]
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "trossen_arm_mujoco.cli",
                *argv,
                "--fps",
                "0.5",
                "--no_progress",
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            cwd=REPO,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        lines: list[tuple[float, str]] = []
        reader = threading.Thread(target=_read_lines, args=(proc.stdout, lines), daemon=True)
        reader.start()
        runs[signum] = (folder, proc, lines, reader)
    try:
        starts = [
            _wait_for(lines, "goal time 6 s per command", 60) for _, _, lines, _ in runs.values()
        ]
        assert None not in starts, runs
        # start move 2 s + settle 0.5 s in real time, then 1.2 s into the first 2 s period
        time.sleep(max(0.0, max(starts) + 3.7 - time.monotonic()))
        sent_at = {}
        for signum, (_, proc, _, _) in runs.items():
            sent_at[signum] = time.monotonic()
            proc.send_signal(signum)
        for signum, (folder, proc, lines, reader) in runs.items():
            name = signal.Signals(signum).name
            stopping = _wait_for(lines, f"stopping: interrupted by {name}", timeout=10)
            assert stopping is not None, lines
            assert stopping - sent_at[signum] < 2.0  # not at the end of the 2 s period
            rc = proc.wait(timeout=60)
            reader.join(timeout=5)
            err = proc.stderr.read()
            assert rc == 128 + signum, (rc, err)
            assert "Traceback" not in err and len(err.strip().splitlines()) == 1
            assert err.startswith("error: replay stopped at step ")
            assert f"interrupted by {name}" in err
            out = [line for _, line in lines]
            assert any(line.endswith("; arms are home and asleep") for line in out), out
            summary = json.loads((folder / "replay/episode_0_sim_summary.json").read_text())
            assert summary["status"] == "interrupted" and summary["steps_done"] < 10
            assert summary["arms_home_and_asleep"] is True
            for final in summary["final_positions"].values():
                np.testing.assert_allclose(final[:6], 0.0, atol=0.01)
            assert temp_files(folder) == []
    finally:
        for _, proc, _, _ in runs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()


# --- --backend wire: the real trossen_arm driver against the served kit (loopback) --------
WIRE = ["--backend", "wire", "--left_ip", "127.0.0.81", "--right_ip", "127.0.0.82"]


def test_wire_backend_replays_through_the_real_driver(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("trossen_arm")
    write_episode(tmp_path, smooth_actions(20))
    rc = run(["--data_dir", str(tmp_path), *WIRE])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert err.strip() == ""  # the driver's own log lines go to stdout
    assert "serving the simulated kit (sim_transfer_cube) on 127.0.0.81 (left)" in out
    assert "replay completed: 20 steps" in out and "arms are home and asleep" in out
    summary = json.loads((tmp_path / "replay/episode_0_wire_summary.json").read_text())
    assert summary["backend"] == "wire" and summary["status"] == "completed"
    assert summary["served"]["faults"] == [] and summary["recovered"] == []
    assert summary["served"]["realtime_factor"] > 0.2
    for pos in summary["final_positions"].values():  # asleep: every joint back at 0
        np.testing.assert_allclose(pos[:6], 0.0, atol=0.03)


def wire_failure(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], steps: int, on_served: Any
) -> tuple[str, str]:
    """Replay ``steps`` smooth steps through the wire backend with ``on_served`` applied to
    the served kit; the run must fail (exit 1) with one error line and no traceback.
    Returns (stdout, the error line)."""
    write_episode(tmp_path, smooth_actions(steps))
    rc = replay_episode_real.cli(
        ["--data_dir", str(tmp_path), *WIRE, "--no_progress"], on_served=on_served
    )
    out, err = capsys.readouterr()
    assert rc == 1, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return out, lines[0]


def test_wire_fault_mid_run_is_one_line_and_every_arm_goes_home(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The served left arm's joint_0 limit is narrowed to 0.1 rad; the episode swings it to
    0.3 rad, so the controller faults mid-stream. Replay stops with one line, clears the
    command-caused error state through the real driver, and takes both arms home."""
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("trossen_arm")
    from trossen_arm_mujoco.real.controller_checks import controller_limits as served_limits

    def narrow(kit: Any) -> None:
        limits = served_limits()
        limits[0].position_max = 0.1
        kit.adapters["left"].set_limits(limits)

    out, line = wire_failure(tmp_path, capsys, 20, narrow)
    assert line.startswith("error: replay stopped at step ")
    assert "Joint limit exceeded" in line and "joint_0: position command" in line
    assert "left arm: cleared the controller's error state joint_limit_exceeded" in out
    assert "arms are home and asleep" in out
    summary = json.loads((tmp_path / "replay/episode_0_wire_summary.json").read_text())
    assert summary["status"] == "failed" and 0 < summary["steps_done"] < 20
    assert summary["arms_home_and_asleep"] and len(summary["recovered"]) == 1
    assert "JOINT_LIMIT_EXCEEDED" in summary["served"]["faults"][0]
    for pos in summary["final_positions"].values():
        np.testing.assert_allclose(pos[:6], 0.0, atol=0.03)


@pytest.mark.parametrize(
    ("ips", "expected"),
    [
        (["--left_ip", "192.168.1.5"], "--left_ip '192.168.1.5' is not an IPv4 loopback"),
        (["--left_ip", "127.0.0.81", "--right_ip", "127.0.0.81"], "are both 127.0.0.81"),
    ],
)
def test_wire_addresses_must_be_loopback_and_distinct(
    ips: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path, smooth_actions(5))
    rc = run(["--data_dir", str(tmp_path), "--backend", "wire", *ips, "--dry_run"])
    assert rc == 2 and expected in one_line_error(capsys)


def test_wire_connection_dropped_mid_run_is_one_line_and_the_other_arm_goes_home(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The served left arm's controller goes away mid-replay (its server stops once the
    commanded joint_0 has swung 0.1 rad of the episode's 0.3: no more answers, as when a
    cable is pulled). Replay stops with one line naming the arm and giving it up, the right
    arm still goes home and to sleep, the summary says so."""
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("trossen_arm")

    def drop_left_mid_replay(kit: Any) -> None:
        adapter, server = kit.adapters["left"], kit.servers["left"]
        handle, dropped = adapter.handle_input, threading.Event()

        def watched(modes, values, now):  # the driver streams inputs at about 1 kHz
            if values[0][0] > START_ARM_POSE[0] + 0.1 and not dropped.is_set():
                dropped.set()
                threading.Thread(target=server.stop, daemon=True).start()
            return handle(modes, values, now)

        adapter.handle_input = watched

    _, line = wire_failure(tmp_path, capsys, 40, drop_left_mid_replay)
    assert line.startswith("error: replay stopped at step ") and "left arm" in line
    assert "left arm: given up (its controller does not answer)" in line
    assert line.count("set_all_positions") == 1  # nothing more sent to the lost arm
    summary = json.loads((tmp_path / "replay/episode_0_wire_summary.json").read_text())
    assert summary["status"] == "failed" and 0 < summary["steps_done"] < 40
    assert list(summary["final_positions"]) == ["right"]  # asleep: every joint back at 0
    np.testing.assert_allclose(summary["final_positions"]["right"][:6], 0.0, atol=0.03)
