"""The record CLI: flags, errors, interrupts."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest

from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.scripts.record_sim_episodes import cli

REPO = Path(__file__).resolve().parents[2]
FAST = ["--episode_len", "20", "--cam_names", "none"]


def _run_cli(args, capsys):
    rc = cli(args)
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_records_and_reports_success_line(tmp_path, capsys):
    rc, out, err = _run_cli(
        ["--data_dir", "d", "--root_dir", str(tmp_path), "--num_episodes", "2", *FAST], capsys
    )
    assert rc == 0
    # said before recording, and again in the last line: the scripted plan needs 440 steps
    assert err.strip() == (
        "warning: --episode_len 20 is shorter than the 440 steps the scripted policy of "
        "'sim_transfer_cube' needs; its episodes will end before the task is done and count "
        "as failed (use --episode_len 440 or more)"
    )
    assert out.strip().splitlines()[-1] == (
        "Success: 0 / 2; 2 of 2 episodes failed: reward below max 4 "
        "(episode_len 20 < 440 the scripted policy needs)"
    )
    sizes = [(tmp_path / "d" / f"episode_{k}.hdf5").stat().st_size for k in (0, 1)]
    for k in (0, 1):  # each episode's line ends with its file size
        line = next(x for x in out.splitlines() if x.startswith(f"episode {k}: "))
        assert line.endswith(f"episode_{k}.hdf5 ({sizes[k] / 1e3:.1f} kB)")
    assert f"dataset: 2 episode(s), {sum(sizes) / 1e3:.1f} kB in {tmp_path / 'd'}" in out
    assert [k for k, _ in list_episodes(tmp_path / "d")] == [0, 1]
    ep = load_episode(tmp_path / "d" / "episode_1.hdf5")
    assert ep.camera_names == [] and ep.num_steps == 20
    assert ep.attrs["task_name"] == "sim_transfer_cube"


def test_long_enough_episodes_succeed_without_warning(tmp_path, capsys):
    rc, out, err = _run_cli(
        ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "440",
         "--cam_names", "none"],
        capsys,
    )  # fmt: skip
    assert rc == 0 and err == ""
    assert out.strip().splitlines()[-1] == "Success: 1 / 1"


def test_images_are_gzip_by_default(tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "3"]
    rc, _, _ = _run_cli([*args, "--cam_names", "cam_high", "--image_size", "12x16"], capsys)
    assert rc == 0
    with h5py.File(tmp_path / "d" / "episode_0.hdf5") as f:
        assert f["observations/images/cam_high"].compression == "gzip"
        assert f["action"].dtype == "float32"


def test_cam_names_subset_and_compression(tmp_path, capsys):
    rc, _, _ = _run_cli(
        [
            "--data_dir",
            "d",
            "--root_dir",
            str(tmp_path),
            "--episode_len",
            "5",
            "--cam_names",
            "cam_low,cam_right_wrist",
            "--image_size",
            "12x16",
            "--compression",
            "none",
        ],
        capsys,
    )
    assert rc == 0
    with h5py.File(tmp_path / "d" / "episode_0.hdf5") as f:
        assert set(f["observations/images"]) == {"cam_low", "cam_right_wrist"}
        assert f["observations/images/cam_low"].compression is None


def test_existing_episodes_are_never_overwritten(tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), *FAST]
    assert _run_cli(args, capsys)[0] == 0
    mtime = (tmp_path / "d" / "episode_0.hdf5").stat().st_mtime_ns
    rc, out, _ = _run_cli(args, capsys)
    assert rc == 0 and "nothing to record" in out
    assert (tmp_path / "d" / "episode_0.hdf5").stat().st_mtime_ns == mtime
    rc, out, _ = _run_cli([*args, "--overwrite"], capsys)
    assert rc == 0 and (tmp_path / "d" / "episode_0.hdf5").stat().st_mtime_ns != mtime


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--task_name", "sim_folding"], "unknown task 'sim_folding'"),
        (["--cam_names", "cam_top"], "unknown camera 'cam_top'"),
        (["--episode_len", "0"], "--episode_len must be at least 1"),
        (["--num_episodes", "0"], "--num_episodes must be at least 1"),
        (["--image_size", "big"], "--image_size must look like"),
        (["--visual", "pretty"], "unknown visual 'pretty'"),
        (["--num_workers", "0"], "--num_workers must be at least 1"),
        (["--ray_address", "auto"], "--ray_address needs --engine ray"),
        (["--engine", "ray", "--onscreen_render"], "--onscreen_render needs --engine local"),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, extra, needle):
    rc, _, err = _run_cli(["--data_dir", "d", "--root_dir", str(tmp_path), *extra], capsys)
    assert rc == 2
    assert needle in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_no_shadows_and_menagerie_visual(tmp_path, capsys, fake_menagerie):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "3"]
    args += ["--cam_names", "cam_high", "--image_size", "12x16"]
    rc, _, err = _run_cli([*args, "--no_shadows", "--visual", "menagerie"], capsys)
    assert rc == 0, err
    ep = load_episode(tmp_path / "d" / "episode_0.hdf5", load_images=True)
    assert ep.attrs["shadows"] == False and ep.attrs["visual"] == "menagerie"  # noqa: E712
    assert ep.images["cam_high"].shape == (3, 12, 16, 3) and ep.images["cam_high"].std() > 0


def test_menagerie_visual_without_checkout_is_one_line_exit_2(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("TROSSEN_MENAGERIE_DIR", raising=False)
    rc, _, err = _run_cli(
        ["--data_dir", "d", "--root_dir", str(tmp_path), "--visual", "menagerie", *FAST], capsys
    )
    assert rc == 2 and "TROSSEN_MENAGERIE_DIR" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "d").exists()


def test_engine_ray_without_ray_says_how_to_install(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    rc, out, err = _run_cli(
        ["--data_dir", "d", "--root_dir", str(tmp_path), *FAST, "--engine", "ray"], capsys
    )
    assert rc == 2 and out == ""
    assert err == 'error: the Ray engine needs Ray: pip install "trossen_arm_mujoco[ray]"\n'


def test_unreachable_ray_address_is_one_line_exit_2(tmp_path, capsys):
    pytest.importorskip("ray")
    import socket

    with socket.socket() as probe:  # a loopback port that nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), *FAST, "--engine", "ray"]
    rc, _, err = _run_cli([*args, "--ray_address", f"127.0.0.1:{port}"], capsys)
    assert rc == 2
    lines = err.strip().splitlines()  # the short --episode_len warning, then the error
    assert lines[-1].startswith(f"error: cannot reach the Ray cluster at 127.0.0.1:{port}: ")
    assert [line for line in lines if line.startswith("error:")] == lines[-1:]


def test_unwritable_root_is_one_line_exit_2(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "trossen_arm_mujoco.scripts.record_sim_episodes",
            "--data_dir",
            "d",
            "--root_dir",
            str(blocker / "sub"),
            *FAST,
        ],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("error: cannot write to")
    assert len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def _default_sigint() -> None:
    """In the child before exec: SIGINT at its default disposition. A test runner started
    as a background job (``pytest &``) has SIGINT ignored, which its children inherit;
    Python then installs no KeyboardInterrupt handler and Ctrl-C would do nothing."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_sigint_keeps_finished_episodes_and_restart_completes(tmp_path):
    data = tmp_path / "d"
    cmd = [
        sys.executable,
        "trossen_arm_mujoco/scripts/record_sim_episodes.py",
        "--data_dir",
        "d",
        "--root_dir",
        str(tmp_path),
        "--num_episodes",
        "3",
        "--episode_len",
        "300",
        "--cam_names",
        "cam_high",
        "--image_size",
        "24x32",
    ]
    proc = subprocess.Popen(
        cmd,
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_sigint,
    )
    deadline = time.time() + 240
    while not (data / "episode_1.hdf5").exists():
        assert proc.poll() is None, proc.communicate()
        assert time.time() < deadline
        time.sleep(0.1)
    time.sleep(1.0)  # well inside episode 2
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "kept" in err and "Traceback" not in err
    assert [k for k, _ in list_episodes(data)] == [0, 1]
    assert sorted(os.listdir(data)) == ["episode_0.hdf5", "episode_1.hdf5"]
    for k in (0, 1):
        assert load_episode(data / f"episode_{k}.hdf5").num_steps == 300
    done = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr
    assert "continuing after existing episode 1" in done.stdout
    assert [k for k, _ in list_episodes(data)] == [0, 1, 2]
    assert load_episode(data / "episode_2.hdf5").attrs["attempt"] == 2


def test_trossen_mujoco_record_dispatch_and_progress_off_a_terminal(tmp_path):
    """Piped output (not a terminal): no redrawn bar (no carriage returns), at most one
    progress line every few seconds instead of one per step."""
    start = time.monotonic()
    proc = subprocess.run(
        [
            sys.executable, "-m", "trossen_arm_mujoco.cli", "record", "--data_dir", "d",
            "--root_dir", str(tmp_path), "--num_episodes", "2", "--episode_len", "300",
            "--cam_names", "none",
        ],
        capture_output=True, text=True, cwd=REPO, timeout=120,
    )  # fmt: skip
    wall = time.monotonic() - start
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1].startswith("Success: 0 / 2; ")
    assert "\r" not in proc.stderr and "\r" not in proc.stdout
    progress = [line for line in proc.stderr.splitlines() if " step (" in line]
    assert len(progress) <= wall / 5 + 1, proc.stderr  # 600 steps recorded


def _xvfb_display():
    import shutil

    if not (shutil.which("Xvfb") and shutil.which("import")):
        pytest.skip("Xvfb and ImageMagick 'import' are needed (apt-get install xvfb imagemagick)")
    for num in range(120, 140):
        if not Path(f"/tmp/.X11-unix/X{num}").exists() and not Path(f"/tmp/.X{num}-lock").exists():
            return num
    pytest.skip("no free X display number")


def test_onscreen_render_shows_live_viewer_under_xvfb(tmp_path):
    import numpy as np
    from PIL import Image

    num = _xvfb_display()
    xvfb = subprocess.Popen(
        ["Xvfb", f":{num}", "-screen", "0", "1280x1024x24"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        time.sleep(1.5)
        env = {**os.environ, "DISPLAY": f":{num}", "MUJOCO_GL": "egl"}
        proc = subprocess.Popen(
            [
                sys.executable,
                "trossen_arm_mujoco/scripts/record_sim_episodes.py",
                "--data_dir",
                "d",
                "--root_dir",
                str(tmp_path),
                "--episode_len",
                "150",
                "--cam_names",
                "cam_high,cam_left_wrist",
                "--image_size",
                "120x160",
                "--onscreen_render",
            ],
            cwd=REPO,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        shot = tmp_path / "screen.png"
        deadline = time.time() + 120
        colours = 0
        while time.time() < deadline and proc.poll() is None:
            time.sleep(2.0)
            subprocess.run(
                ["import", "-display", f":{num}", "-window", "root", str(shot)],
                capture_output=True,
                timeout=30,
            )
            if shot.exists():
                img = np.asarray(Image.open(shot).convert("RGB"))
                colours = len(np.unique(img.reshape(-1, 3), axis=0))
                if colours > 200:
                    break
        out, err = proc.communicate(timeout=180)
        assert proc.returncode == 0, err
        assert "live view off" not in err
        assert colours > 200, f"screenshot looks blank ({colours} colours)"
    finally:
        xvfb.terminate()
        xvfb.wait(timeout=10)


def test_randomize_flag_stores_the_randomization(tmp_path, capsys):
    from trossen_arm_mujoco.tasks.randomization import record_from_json

    args = ["--root_dir", str(tmp_path), "--episode_len", "5", "--cam_names", "none"]
    rc, out, _ = _run_cli(["--data_dir", "r", "--randomize", "--num_workers", "2",
                           "--num_episodes", "2", *args], capsys)  # fmt: skip
    assert rc == 0 and "randomized" in out
    records = [record_from_json(load_episode(tmp_path / "r" / f"episode_{k}.hdf5")
                                .attrs["randomization"]) for k in (0, 1)]  # fmt: skip
    assert records[0]["version"] == 1 and records[0] != records[1]
    rc, out, _ = _run_cli(["--data_dir", "p", *args], capsys)
    assert rc == 0 and "randomized" not in out
    assert "randomization" not in load_episode(tmp_path / "p" / "episode_0.hdf5").attrs
