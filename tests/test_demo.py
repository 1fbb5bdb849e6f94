"""The demo behind ``python trossen_arm_mujoco/ee_sim_env.py`` / ``sim_env.py``.

Headless runs write one PNG per camera; the live viewer is checked under Xvfb when the
X tools are installed (CI: apt packages xvfb, x11-apps, imagemagick).
"""

from __future__ import annotations

import contextlib
import os
import select
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from trossen_arm_mujoco import demo
from trossen_arm_mujoco.constants import DT, GRIPPER_OPEN, START_ARM_POSE, STATIONARY_CAMERAS
from trossen_arm_mujoco.demo import demo_main, scripted_action
from trossen_arm_mujoco.utils import make_sim_env

REPO = Path(__file__).resolve().parents[1]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def read_png(path: Path) -> np.ndarray:
    from PIL import Image

    assert path.read_bytes()[:8] == PNG_SIGNATURE
    with Image.open(path) as img:
        return np.asarray(img.convert("RGB"))


def headless_env() -> dict[str, str]:
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    env.pop("DISPLAY", None)
    env.pop("WAYLAND_DISPLAY", None)
    return env


def run_python(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    """``python *args`` from the repo root, without a display unless env says otherwise."""
    return subprocess.run(
        [sys.executable, *args],
        cwd=REPO,
        env=headless_env() if env is None else env,
        capture_output=True,
        text=True,
        timeout=120,
    )


def check_pngs(out_dir: Path, flavour: str) -> None:
    files = sorted(out_dir.glob("*.png"))
    assert [f.name for f in files] == sorted(f"{flavour}_{c}.png" for c in STATIONARY_CAMERAS)
    for f in files:
        img = read_png(f)
        assert img.shape == (480, 640, 3), f.name
        assert img.std() > 10, f"{f.name} looks blank"
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 50, f"{f.name} has few colours"


# ----------------------------------------------------------------------------- headless
@pytest.mark.parametrize("flavour", ["ee", "joint"])
def test_headless_demo_writes_four_pngs(flavour, tmp_path, capsys):
    rc = demo_main(flavour, ["--headless", "--seconds", "1", "--out_dir", str(tmp_path)])
    assert rc == 0
    check_pngs(tmp_path, flavour)
    printed = capsys.readouterr().out.split()
    assert sorted(printed) == sorted(str(p) for p in tmp_path.glob("*.png"))


def test_file_run_from_repo_root(tmp_path):
    """The documented command works as a plain file run (no -m, no install needed)."""
    args = ["--headless", "--seconds", "0.2", "--out_dir", str(tmp_path)]
    proc = run_python("trossen_arm_mujoco/ee_sim_env.py", *args)
    assert proc.returncode == 0, proc.stderr
    check_pngs(tmp_path, "ee")
    assert str(tmp_path / "ee_cam_high.png") in proc.stdout
    assert "Traceback" not in proc.stderr


def test_no_display_falls_back_to_headless(tmp_path):
    proc = run_python(
        "trossen_arm_mujoco/sim_env.py", "--seconds", "0.1", "--out_dir", str(tmp_path)
    )
    assert proc.returncode == 0, proc.stderr
    assert "note: no DISPLAY; running headless" in proc.stdout
    check_pngs(tmp_path, "joint")


@pytest.mark.parametrize(
    "command",
    [
        ["trossen_arm_mujoco/sim_env.py"],
        # mujoco imported first, without MUJOCO_GL: it picks GLFW, which cannot render here
        [
            "-c",
            "import sys, mujoco; from trossen_arm_mujoco.demo import demo_main; "
            "sys.exit(demo_main('joint'))",
        ],
    ],
    ids=["file_run", "mujoco_imported_first"],
)
def test_without_mujoco_gl_and_display_still_renders(command, tmp_path):
    env = headless_env()
    env.pop("MUJOCO_GL", None)
    args = ["--headless", "--seconds", "0.1", "--out_dir", str(tmp_path)]
    proc = run_python(*command, *args, env=env)
    assert proc.returncode == 0, proc.stderr
    check_pngs(tmp_path, "joint")


def test_default_out_dir_is_a_new_temp_folder(capsys, monkeypatch, tmp_path):
    monkeypatch.setattr(demo.tempfile, "tempdir", str(tmp_path))
    assert demo_main("joint", ["--headless", "--seconds", "0.1"]) == 0
    paths = [Path(p) for p in capsys.readouterr().out.split()]
    assert len(paths) == 4
    assert paths[0].parent.parent == tmp_path
    assert paths[0].parent.name.startswith("trossen_demo_joint_")


@pytest.mark.parametrize(
    ("flavour", "argv", "message"),
    [
        ("arm", ["--headless"], "unknown demo flavour 'arm'; valid: ee, joint"),
        ("ee", ["--headless", "--seconds", "0"], "--seconds must be a positive number"),
        ("ee", ["--headless", "--seconds", "nan"], "--seconds must be a positive number"),
    ],
)
def test_user_errors_are_one_line(flavour, argv, message, capsys):
    assert demo_main(flavour, argv) == 2
    err = capsys.readouterr().err
    assert err.strip() == f"error: {message}" or err.startswith(f"error: {message}")
    assert "Traceback" not in err


def test_help(capsys):
    with pytest.raises(SystemExit) as exc:
        demo_main("ee", ["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "python trossen_arm_mujoco/ee_sim_env.py" in out
    for flag in ("--seconds", "--headless", "--out_dir"):
        assert flag in out


# ----------------------------------------------------------------------------- pieces
@pytest.mark.parametrize("flavour", ["ee", "joint"])
def test_scripted_motion_starts_at_the_initial_pose_and_is_smooth(flavour):
    task = demo._task_class(flavour)
    env = make_sim_env(task, cam_list=[], random=0)
    ts = env.reset()
    spec = env.action_spec()
    action = scripted_action(flavour, ts.observation, spec.minimum, spec.maximum)
    a0 = action(0.0)
    if flavour == "ee":
        expected = np.concatenate(
            [
                ts.observation["mocap_pose_left"],
                [GRIPPER_OPEN],
                ts.observation["mocap_pose_right"],
                [GRIPPER_OPEN],
            ]
        )
    else:
        expected = np.array(START_ARM_POSE)
    np.testing.assert_allclose(a0, expected, atol=1e-12)
    times = np.arange(0, 12.0, DT)
    actions = np.array([action(t) for t in times])
    assert np.all(actions >= spec.minimum) and np.all(actions <= spec.maximum)
    assert np.abs(np.diff(actions, axis=0)).max() < 0.05  # no jumps between steps
    assert np.ptp(actions, axis=0).max() > 0.02  # it does move
    # the robot follows without warnings
    for a in actions[:100]:
        env.step(a)
    assert all(w.number == 0 for w in env.physics.data.ptr.warning)
    env.task.close()


def test_display_problem_without_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    assert demo.display_problem() == "no DISPLAY"


def test_display_problem_with_unreachable_display(monkeypatch):
    monkeypatch.setenv("DISPLAY", ":4321")  # nothing listens there
    problem = demo.display_problem()
    assert problem is not None


def test_live_failure_falls_back_to_headless(monkeypatch, tmp_path, capsys):
    def broken_live(*args):
        raise RuntimeError("GLX is missing\nsecond line")

    monkeypatch.setattr(demo, "display_problem", lambda: None)
    monkeypatch.setattr(demo, "run_live", broken_live)
    assert demo_main("joint", ["--seconds", "0.1", "--out_dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "note: live viewer failed: GLX is missing; running headless" in out
    check_pngs(tmp_path, "joint")


def test_viewer_launch_gives_up_instead_of_hanging(monkeypatch):
    mujoco_viewer = pytest.importorskip("mujoco.viewer")

    def never_returns(*args, **kwargs):
        time.sleep(60)

    monkeypatch.setattr(mujoco_viewer, "launch_passive", never_returns)
    start = time.monotonic()
    with pytest.raises(RuntimeError, match="did not open within 0.5 s"):
        demo.launch_viewer(None, None, timeout=0.5)
    assert time.monotonic() - start < 5


def test_viewer_launch_error_is_reported(monkeypatch):
    mujoco_viewer = pytest.importorskip("mujoco.viewer")

    def fails(*args, **kwargs):
        raise ValueError("no window")

    monkeypatch.setattr(mujoco_viewer, "launch_passive", fails)
    with pytest.raises(RuntimeError, match="viewer failed to start: no window"):
        demo.launch_viewer(None, None, timeout=5)


class FakeViewer:
    """Stands in for the passive viewer handle: the window "closes" after ``frames`` syncs."""

    def __init__(self, frames: float = float("inf")):
        self.frames = frames
        self.synced = 0
        self.closed = False
        self.cam = SimpleNamespace(lookat=np.zeros(3), distance=0.0, azimuth=0.0, elevation=0.0)

    def is_running(self) -> bool:
        return not self.closed and self.synced < self.frames

    def lock(self):
        return contextlib.nullcontext() if self.is_running() else None

    def sync(self) -> None:
        self.synced += 1

    def close(self) -> None:
        self.closed = True


def test_live_loop_stops_when_the_window_closes(monkeypatch, capsys):
    viewer = FakeViewer(frames=10)
    monkeypatch.setattr(demo, "launch_viewer", lambda model, data: (viewer, []))
    start = time.monotonic()
    demo.run_live("joint", seconds=100.0, seed=0)
    assert viewer.synced == 10 and viewer.closed
    assert time.monotonic() - start < 10
    assert "live viewer running (joint)" in capsys.readouterr().out


def test_live_loop_runs_in_real_time_for_the_given_seconds(monkeypatch):
    viewer = FakeViewer()
    monkeypatch.setattr(demo, "launch_viewer", lambda model, data: (viewer, []))
    start = time.monotonic()
    demo.run_live("ee", seconds=0.3, seed=0)
    elapsed = time.monotonic() - start
    assert abs(viewer.synced - round(0.3 / DT)) <= 1 and viewer.closed
    assert elapsed >= 0.3  # paced to the wall clock, not as fast as possible


# ----------------------------------------------------------------------------- live viewer
def _readline(proc: subprocess.Popen, timeout: float) -> str:
    """The next stdout line of ``proc``, or "" after ``timeout`` s without one."""
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    return proc.stdout.readline() if ready else ""


def _looks_like_the_scene(rgb: np.ndarray, xscreen) -> None:
    """The screenshot (H, W, 3) shows the scene: many colours, arm links and the table."""
    colours = len(xscreen.colours_of(rgb))
    pixels = rgb.reshape(-1, 3).astype(int)
    brightest = pixels.max(axis=1)
    robot = np.count_nonzero((brightest > 8) & (brightest < 70))  # dark grey arm links
    table = np.count_nonzero((pixels[:, 0] > 150) & (pixels[:, 0] > pixels[:, 2] + 40))  # maple
    assert colours > 200, f"the screenshot looks blank ({colours} colours): {xscreen.report()}"
    assert robot > 2000, f"no robot pixels in the screenshot ({robot})"
    assert table > 2000, f"no table pixels in the screenshot ({table})"


@pytest.mark.parametrize(("script", "seconds"), [("ee_sim_env.py", "6"), ("sim_env.py", "4.5")])
def test_live_viewer_under_xvfb(script, seconds, tmp_path, xscreen):
    display = xscreen.display
    demo_proc = None
    try:
        env = dict(os.environ, DISPLAY=display, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
        fallback_dir = tmp_path / "fallback"
        demo_proc = subprocess.Popen(
            [
                sys.executable,
                f"trossen_arm_mujoco/{script}",
                "--seconds",
                "6",
                "--out_dir",
                str(fallback_dir),
            ],
            cwd=REPO,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        first_line = _readline(demo_proc, timeout=60)
        if not first_line.startswith("live viewer running"):
            demo_proc.kill()
            out, err = demo_proc.communicate(timeout=30)
            pytest.fail(f"the live viewer did not start under Xvfb:\n{first_line}{out}{err}")
        time.sleep(2.5)  # the viewer shows a few seconds of the motion
        rgb = xscreen.screenshot(tmp_path / "live_viewer.xwd")
        out, err = demo_proc.communicate(timeout=60)
        assert demo_proc.returncode == 0, err
        assert "Traceback" not in err and "X Error" not in err, err
        assert not fallback_dir.exists()  # no headless fallback happened
        assert rgb is not None, f"no screenshot taken: {xscreen.report()}"
        _looks_like_the_scene(rgb, xscreen)
    finally:
        if demo_proc is not None and demo_proc.poll() is None:
            demo_proc.kill()
            demo_proc.wait(10)
