"""No crash at exit wherever the ``trossen_arm`` driver was loaded, addresses checked before
anything connects, and the outputs of ``replay-real`` checked before any arm moves.

The exit tests run the commands in a subprocess, through the real ``trossen_arm`` driver,
against loopback addresses only: 127.0.0.121 .. 127.0.0.129 (this module's block, see
``tests/twin/conftest.py``). Nothing listens on 127.0.0.121 / .122 / .125 / .126 (an
unreachable controller); the simulated kit is served on 127.0.0.123 / .124.

Before the fix, each of these processes printed its error line and then died with SIGSEGV
at interpreter exit (status 139 / -11): ``trossen_arm`` keeps the Python log backend
(``set_logger_backend``) in a C++ static destroyed by the C library's exit handlers, after
the interpreter has finalized.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import types
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pytest

from trossen_arm_mujoco.constants import START_ARM_POSE
from trossen_arm_mujoco.real import driver as driver_module
from trossen_arm_mujoco.real.preflight import check_arm_ips, check_ip
from trossen_arm_mujoco.scripts import replay_episode_real

REPO = Path(__file__).resolve().parents[2]
UNREACHABLE = ("127.0.0.121", "127.0.0.122")
SERVED = ("127.0.0.123", "127.0.0.124")
LEADERS = ("127.0.0.125", "127.0.0.126")
#: Exit statuses of a process killed by SIGSEGV, as subprocess and as a shell report them.
CRASHED = (-signal.SIGSEGV, 128 + signal.SIGSEGV)


def write_episode(folder: Path, steps: int = 5) -> Path:
    """A short episode in this project's layout (plain h5py): the arms turn joint_0 by
    0.01 rad per step from the start pose, the grippers stay half open."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "episode_0.hdf5"
    actions = np.tile(np.asarray(START_ARM_POSE, dtype=np.float64), (steps, 1))
    actions[:, [0, 8]] += 0.01 * np.arange(steps)[:, None]
    actions[:, [6, 7, 14, 15]] = 0.02
    with h5py.File(path, "w") as f:
        f.attrs["sim"] = True
        f.create_dataset("observations/qpos", data=actions)
        f.create_dataset("observations/qvel", data=np.zeros_like(actions))
        f.create_dataset("action", data=actions)
    return path


def run_command(args: list[str], timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    """``python -X faulthandler -m <args>`` from the repository root, output captured."""
    for arg in args:  # belt and braces: these tests never reach beyond this machine
        if arg.count(".") == 3 and arg[:1].isdigit() and ":" not in arg:
            assert arg.startswith("127."), f"non-loopback address {arg!r} in a test"
    env = dict(os.environ, MUJOCO_GL="egl", PYTHONFAULTHANDLER="1")
    return subprocess.run(
        [sys.executable, "-X", "faulthandler", "-m", *args],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def assert_one_error_line(proc: subprocess.CompletedProcess[str], status: int) -> str:
    """The process exited with ``status`` (not a crash) after exactly one ``error:`` line."""
    assert proc.returncode not in CRASHED, f"crashed at exit:\n{proc.stderr}"
    assert proc.returncode == status, proc.stderr
    assert "Traceback" not in proc.stderr and "Fatal Python error" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    return lines[0]


REPLAY = "trossen_arm_mujoco.scripts.replay_episode_real"


def test_unreachable_controller_is_one_line_and_no_crash_at_exit(tmp_path: Path) -> None:
    pytest.importorskip("trossen_arm")
    write_episode(tmp_path)
    left, right = UNREACHABLE
    proc = run_command(
        [
            REPLAY,
            "--data_dir",
            str(tmp_path),
            "--left_ip",
            left,
            "--right_ip",
            right,
            "--connect_timeout",
            "1",
            "--no_progress",
        ]
    )
    line = assert_one_error_line(proc, 1)
    assert line.startswith(
        f"error: replay stopped at step 0/5: left arm: configure ({left}) failed: Failed to connect"
    )
    assert "no arm was configured, none moved" in proc.stdout
    summary = json.loads((tmp_path / "replay/episode_0_trossen_summary.json").read_text())
    assert summary["status"] == "failed" and summary["steps_done"] == 0


def test_wire_backend_replay_exits_without_a_crash(tmp_path: Path) -> None:
    pytest.importorskip("trossen_arm_sim")
    pytest.importorskip("trossen_arm")
    write_episode(tmp_path, steps=3)
    left, right = SERVED
    proc = run_command(
        [
            REPLAY,
            "--data_dir",
            str(tmp_path),
            "--backend",
            "wire",
            "--left_ip",
            left,
            "--right_ip",
            right,
            "--no_progress",
        ]
    )
    assert proc.returncode not in CRASHED, f"crashed at exit:\n{proc.stderr}"
    assert proc.returncode == 0 and proc.stderr.strip() == "", proc.stderr
    assert "replay completed: 3 steps" in proc.stdout


def test_malformed_address_is_one_line_before_the_driver_is_loaded(tmp_path: Path) -> None:
    write_episode(tmp_path)
    proc = run_command(
        [
            REPLAY,
            "--data_dir",
            str(tmp_path),
            "--left_ip",
            "127.0.0.1:notaport",
            "--right_ip",
            UNREACHABLE[1],
            "--no_progress",
        ]
    )
    line = assert_one_error_line(proc, 2)
    assert line.startswith("error: --left_ip '127.0.0.1:notaport' is not an IPv4 address")
    assert not (tmp_path / "replay").exists()


def test_driver_left_connected_or_failed_in_a_script_exits_cleanly() -> None:
    """The library path, without the command's cleanup: ``atexit`` releases the backend."""
    pytest.importorskip("trossen_arm")
    code = (
        "from trossen_arm_mujoco.real.driver import TrossenArmDriver\n"
        "d = TrossenArmDriver(connect_timeout=0.5)\n"
        "try:\n"
        f"    d.configure({UNREACHABLE[0]!r})\n"
        "except RuntimeError:\n"
        "    print('configure failed', flush=True)\n"
        "other = TrossenArmDriver()  # constructed, never configured, never cleaned up\n"
    )
    env = dict(os.environ, MUJOCO_GL="egl")
    proc = subprocess.run(
        [sys.executable, "-X", "faulthandler", "-c", code],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, f"exit status {proc.returncode}:\n{proc.stderr}"
    assert "configure failed" in proc.stdout and proc.stderr.strip() == ""


def test_teleop_with_unreachable_leaders_exits_without_a_crash(tmp_path: Path) -> None:
    pytest.importorskip("trossen_arm")
    proc = run_command(
        [
            "trossen_arm_mujoco.scripts.teleop",
            "--leader_left_ip",
            LEADERS[0],
            "--leader_right_ip",
            LEADERS[1],
            "--data_dir",
            str(tmp_path / "d"),
            "--connect_timeout",
            "1",
            "--cam_names",
            "none",
        ]
    )
    line = assert_one_error_line(proc, 1)
    assert f"cannot connect to the left leader arm at {LEADERS[0]}" in line


# --- in-process: the checks themselves -------------------------------------------------


def run(argv: list[str]) -> int:
    return replay_episode_real.cli([*argv, "--no_progress"])


def one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert "Traceback" not in err and len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


@pytest.mark.parametrize(
    ("flag", "value", "why"),
    [
        ("--left_ip", "127.0.0.1:notaport", "give the address alone"),
        ("--right_ip", "300.1.1.1", "four numbers 0-255"),
        ("--left_ip", "", "it is empty"),
        ("--right_ip", "  ", "it is empty"),
        ("--left_ip", "arm.local", "four numbers 0-255"),
        ("--left_ip", "0.0.0.0", "cannot be an arm controller's address"),
    ],
)
@pytest.mark.parametrize("dry_run", [False, True])
def test_bad_address_is_one_line_naming_the_flag(
    flag: str,
    value: str,
    why: str,
    dry_run: bool,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def no_driver(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a driver was made before the addresses were checked")

    monkeypatch.setattr(replay_episode_real, "make_drivers", no_driver)
    write_episode(tmp_path)
    other = "--right_ip" if flag == "--left_ip" else "--left_ip"
    argv = ["--data_dir", str(tmp_path), flag, value, other, UNREACHABLE[0]]
    rc = run([*argv, *(["--dry_run"] * dry_run)])
    line = one_line_error(capsys)
    assert rc == 2 and line.startswith(f"error: {flag} ") and why in line
    assert not (tmp_path / "replay").exists()


def test_same_address_for_both_arms_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path)
    rc = run(
        ["--data_dir", str(tmp_path), "--left_ip", "127.0.0.121", "--right_ip", " 127.0.0.121"]
    )
    line = one_line_error(capsys)
    assert rc == 2 and "--left_ip and --right_ip are both 127.0.0.121" in line


def test_check_ip_normalizes_and_accepts_any_unicast_ipv4() -> None:
    assert check_ip(" 192.168.1.5 ", "--left_ip") == "192.168.1.5"
    assert check_arm_ips(
        {"left": "10.0.0.1", "right": "10.0.0.2"}, {"left": "-l", "right": "-r"}
    ) == {"left": "10.0.0.1", "right": "10.0.0.2"}
    with pytest.raises(Exception, match="--left_ip '::1' is not an IPv4 address"):
        check_ip("::1", "--left_ip")


def test_release_cleans_up_live_drivers_then_uninstalls_the_backend(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Order matters: a driver's cleanup may still log; the backend goes last."""
    events: list[str] = []

    class FakeRawDriver:
        def configure(self, *args: Any) -> None:
            events.append(f"configure {args[2]} timeout={args[4]}")

        def cleanup(self) -> None:
            events.append("cleanup")

    class FakeTrossenArmDriver(FakeRawDriver):
        get_all_positions = None

        @staticmethod
        def set_logger_backend(backend: Any) -> None:
            events.append("backend None" if backend is None else "backend set")

    fake = types.SimpleNamespace(
        TrossenArmDriver=FakeTrossenArmDriver,
        Model=types.SimpleNamespace(wxai_v0="model"),
        StandardEndEffector=types.SimpleNamespace(wxai_v0_follower="ee"),
    )
    registered: list[Any] = []
    monkeypatch.setattr(driver_module, "import_trossen_arm", lambda: fake)
    monkeypatch.setattr(driver_module, "find_trossen_arm", lambda: fake)
    monkeypatch.setattr(driver_module.atexit, "register", lambda *a: registered.append(a))
    monkeypatch.setattr(driver_module, "_LOG_STATE", {"routed": False, "atexit": False})
    monkeypatch.setattr(driver_module, "_LIVE_DRIVERS", driver_module.weakref.WeakSet())
    monkeypatch.setattr(driver_module, "resolve_presets", lambda ta, m, e: ("model", "ee"))

    drv = driver_module.TrossenArmDriver(connect_timeout=3.0)
    drv.configure("127.0.0.121")
    assert registered == [(driver_module.release_driver_logs, fake)]
    assert events == ["backend set", "configure 127.0.0.121 timeout=3.0"]
    events.clear()
    driver_module.release_driver_logs(fake)
    assert events == ["cleanup", "backend None"]
    events.clear()
    driver_module.release_driver_logs(fake)  # twice: nothing left to do
    drv.cleanup()  # already released: idempotent
    assert events == []


def test_failed_configure_releases_the_driver(monkeypatch: pytest.MonkeyPatch) -> None:
    events: list[str] = []

    class FailingDriver:
        get_all_positions = None

        def configure(self, *args: Any) -> None:
            raise RuntimeError("Failed to connect")

        def cleanup(self) -> None:
            events.append("cleanup")

        @staticmethod
        def set_logger_backend(backend: Any) -> None:
            pass

    fake = types.SimpleNamespace(TrossenArmDriver=FailingDriver)
    monkeypatch.setattr(driver_module, "import_trossen_arm", lambda: fake)
    monkeypatch.setattr(driver_module, "resolve_presets", lambda ta, m, e: ("model", "ee"))
    monkeypatch.setattr(driver_module, "_LOG_STATE", {"routed": False, "atexit": True})
    drv = driver_module.TrossenArmDriver()
    with pytest.raises(RuntimeError, match="Failed to connect") as exc_info:
        drv.configure("127.0.0.121")
    assert events == ["cleanup"] and drv._driver is None
    frame = exc_info.tb.tb_next.tb_frame  # configure's frame, kept by the traceback
    assert "driver" not in frame.f_locals
    assert drv not in driver_module._LIVE_DRIVERS


# --- outputs checked before any arm moves ------------------------------------------------


class NoDrivers:
    """A driver factory that fails the test: nothing may be built."""

    def __call__(self, *args: Any) -> Any:
        raise AssertionError("drivers were made before the outputs were checked")


def test_output_dir_under_a_regular_file_is_one_line_before_anything_moves(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path / "data")
    blocker = tmp_path / "notes.txt"
    blocker.write_text("a file, not a folder\n")
    argv = [
        "--data_dir",
        str(tmp_path / "data"),
        "--backend",
        "sim",
        "--output_dir",
        str(blocker / "replay"),
    ]
    rc = replay_episode_real.cli([*argv, "--no_progress"], driver_factory=NoDrivers())
    line = one_line_error(capsys)
    assert rc == 2 and line.startswith(f"error: cannot write to --output_dir {blocker / 'replay'}")
    assert "a file is in the way" in line and "choose another --output_dir" in line
    assert blocker.read_text() == "a file, not a folder\n"


def test_default_output_folder_is_a_file_names_the_flag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path)
    (tmp_path / "replay").write_text("in the way\n")
    rc = replay_episode_real.cli(
        ["--data_dir", str(tmp_path), "--backend", "sim", "--no_progress"],
        driver_factory=NoDrivers(),
    )
    line = one_line_error(capsys)
    assert rc == 2 and "--output_dir" in line and "it is a file" in line


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes in read-only folders")
def test_read_only_output_folder_is_refused_before_anything_moves(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path)
    out = tmp_path / "ro"
    out.mkdir()
    out.chmod(0o500)
    try:
        rc = replay_episode_real.cli(
            [
                "--data_dir",
                str(tmp_path),
                "--backend",
                "sim",
                "--output_dir",
                str(out),
                "--no_progress",
            ],
            driver_factory=NoDrivers(),
        )
    finally:
        out.chmod(0o700)
    line = one_line_error(capsys)
    assert rc == 2 and "--output_dir" in line and "permission" in line.lower()


def test_a_folder_where_a_result_file_goes_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path)
    (tmp_path / "replay" / "episode_0_sim_summary.json").mkdir(parents=True)
    rc = replay_episode_real.cli(
        ["--data_dir", str(tmp_path), "--backend", "sim", "--no_progress"],
        driver_factory=NoDrivers(),
    )
    line = one_line_error(capsys)
    assert rc == 2 and "episode_0_sim_summary.json there is a folder" in line
    assert "choose another --output_dir" in line


def test_output_dir_flag_receives_the_results(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path / "data")
    out = tmp_path / "results" / "run1"
    rc = run(["--data_dir", str(tmp_path / "data"), "--backend", "sim", "--output_dir", str(out)])
    assert rc == 0, capsys.readouterr().err
    summary = json.loads((out / "episode_0_sim_summary.json").read_text())
    assert summary["status"] == "completed"
    assert (out / "episode_0_sim_tracking.csv").is_file()
    assert not (tmp_path / "data" / "replay").exists()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no probe, no temp file


@pytest.mark.parametrize("value", ["0", "-1", "nan", "1e9"])
def test_connect_timeout_out_of_range_is_one_line(
    value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path)
    rc = run(["--data_dir", str(tmp_path), "--connect_timeout", value, "--dry_run"])
    line = one_line_error(capsys)
    assert rc == 2 and line.startswith("error: --connect_timeout must be in (0, 600] s")


# --- hints name the flag that fixes the problem -------------------------------------------


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        (["--episode_idx", "7"], "holds episode 0: pass one of them with --episode_idx"),
        (["--episode_idx", "-1"], "--episode_idx must be >= 0, got -1"),
        (["--output_dir", " "], "--output_dir must not be empty"),
    ],
)
def test_hints_name_the_flag(
    extra: list[str], expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_episode(tmp_path)
    rc = replay_episode_real.cli(
        ["--data_dir", str(tmp_path), "--backend", "sim", "--no_progress", *extra],
        driver_factory=NoDrivers(),
    )
    line = one_line_error(capsys)
    assert rc == 2 and expected in line, line


def test_missing_data_folder_names_data_dir(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = run(["--data_dir", str(tmp_path / "nope"), "--dry_run"])
    line = one_line_error(capsys)
    assert rc == 2 and "data folder not found" in line and "check --data_dir" in line


def test_check_end_effector_can_name_the_flag() -> None:
    ta = pytest.importorskip("trossen_arm")
    with pytest.raises(Exception, match=r"; pass one of them with --end_effector\)$"):
        driver_module.check_end_effector(ta, "wxai_v0_folower", flag="--end_effector")
