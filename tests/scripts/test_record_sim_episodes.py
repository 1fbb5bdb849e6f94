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
from trossen_arm_mujoco.processes import available_cpus
from trossen_arm_mujoco.scripts.record_sim_episodes import cli

REPO = Path(__file__).resolve().parents[2]
FAST = ["--episode_len", "20", "--cam_names", "none"]
#: The shortest episodes the scripted transfer succeeds in, state only.
SUCCEEDS = ["--episode_len", "440", "--cam_names", "none"]


def rc_failed(proc) -> bool:
    """Exit status 1: the run finished, some episodes failed."""
    return proc.returncode == 1


def _run_cli(args, capsys):
    rc = cli(args)
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_records_and_reports_success_line(tmp_path, capsys):
    rc, out, err = _run_cli(
        ["--data_dir", "d", "--root_dir", str(tmp_path), "--num_episodes", "2", *FAST], capsys
    )
    assert rc == 1  # some episodes failed: scripts can tell
    # said before recording, and again in the last line: the scripted plan needs 440 steps
    assert err.strip().splitlines() == [
        "warning: --episode_len 20 is shorter than the 440 steps the scripted policy of "
        "'sim_transfer_cube' needs; its episodes will end before the task is done and count "
        "as failed (use --episode_len 440 or more)",
        "failed: episodes 0..1 kept with success=False; rerunning the same command records "
        "them again (or pass --skip_failed to keep only successes)",
    ]
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
        [
            "--data_dir",
            "d",
            "--root_dir",
            str(tmp_path),
            "--episode_len",
            "440",
            "--cam_names",
            "none",
        ],
        capsys,
    )
    assert rc == 0 and err == ""
    assert out.strip().splitlines()[-1] == "Success: 1 / 1"


def test_images_are_gzip_by_default(tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "3"]
    rc, _, _ = _run_cli([*args, "--cam_names", "cam_high", "--image_size", "12x16"], capsys)
    assert rc == 1  # 3 steps: the episode fails, and is kept
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
    assert rc == 1
    with h5py.File(tmp_path / "d" / "episode_0.hdf5") as f:
        assert set(f["observations/images"]) == {"cam_low", "cam_right_wrist"}
        assert f["observations/images/cam_low"].compression is None


def test_successful_episodes_are_never_overwritten(tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), *SUCCEEDS]
    assert _run_cli(args, capsys)[0] == 0
    mtime = (tmp_path / "d" / "episode_0.hdf5").stat().st_mtime_ns
    rc, out, _ = _run_cli(args, capsys)
    assert rc == 0 and out.strip() == (
        f"{tmp_path / 'd'} already holds episode 0; nothing to record (raise --num_episodes "
        "to add more, or --overwrite to start afresh)"
    )
    assert (tmp_path / "d" / "episode_0.hdf5").stat().st_mtime_ns == mtime
    rc, out, _ = _run_cli([*args, "--overwrite"], capsys)
    assert rc == 0 and (tmp_path / "d" / "episode_0.hdf5").stat().st_mtime_ns != mtime


def test_failures_exit_1_and_a_rerun_records_them_again(tmp_path, capsys):
    """30 steps are too short for the scripted policy: every episode fails. The run says so
    with exit status 1, keeps the files, and a rerun records them again (new attempts)."""
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--num_episodes", "2"]
    args += ["--episode_len", "30", "--cam_names", "none"]
    rc, out, err = _run_cli(args, capsys)
    assert rc == 1
    assert out.strip().splitlines()[-1].startswith("Success: 0 / 2; 2 of 2 episodes failed")
    assert err.strip().splitlines()[-1].startswith("failed: episodes 0..1 kept with success=False")
    rc, out, err = _run_cli(args, capsys)
    assert rc == 1 and "nothing to record" not in out
    assert (
        f"continuing the dataset in {tmp_path / 'd'}: failed before, recording again: "
        "episodes 0..1" in out
    )
    attempts = [load_episode(p).attrs["attempt"] for _, p in list_episodes(tmp_path / "d")]
    assert attempts == [2, 3]
    assert sorted(os.listdir(tmp_path / "d")) == ["episode_0.hdf5", "episode_1.hdf5"]


def test_resume_with_other_flags_is_refused_and_gaps_are_named(tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--cam_names", "none"]
    assert _run_cli([*args, "--episode_len", "440", "--num_episodes", "3"], capsys)[0] == 0
    rc, out, err = _run_cli([*args, "--episode_len", "441", "--seed", "3"], capsys)
    assert rc == 2 and out == ""
    assert err == (
        f"error: {tmp_path / 'd'} holds episodes recorded with other settings than this run "
        "(episode_0.hdf5: --seed 0 (this run: 3); --episode_len 440 (this run: 441)); rerun "
        "with the dataset's flags to continue it, or choose another --data_dir for a new "
        "dataset (--overwrite replaces its episodes)\n"
    )
    (tmp_path / "d" / "episode_1.hdf5").unlink()
    (tmp_path / "d" / "episode_2.hdf5").rename(tmp_path / "d" / "episode_5.hdf5")
    rc, out, _ = _run_cli([*args, "--episode_len", "440", "--num_episodes", "2"], capsys)
    assert rc == 0
    assert out.splitlines()[0] == (
        f"continuing the dataset in {tmp_path / 'd'}: keeping episodes 0, 5; missing: episode 1"
    )
    assert out.splitlines()[1].startswith("recording episode 1 of 'sim_transfer_cube'")
    rc, out, _ = _run_cli([*args, "--episode_len", "440", "--num_episodes", "2"], capsys)
    assert out.startswith(f"{tmp_path / 'd'} already holds episodes 0..1, 5; nothing to record")


@pytest.mark.parametrize(
    "extra, needle",
    [
        (["--task_name", "sim_folding"], "unknown task 'sim_folding'"),
        (["--seed", "-1"], "--seed must be in 0 .. 2**63-1"),
        (["--seed", str(2**64)], "--seed must be in 0 .. 2**63-1"),
        (["--seed", str(2**63)], "--seed must be in 0 .. 2**63-1"),
        (["--seed", "x"], "argument --seed: invalid int value: 'x'"),
        (["--episode_len", "1e13"], "argument --episode_len: invalid int value: '1e13'"),
        (["--episode_len", str(10**13)], "--episode_len must be in 1 .. 100000 steps"),
        (["--num_episodes", str(10**12)], "--num_episodes must be in 1 .. 1000000"),
        (["--engine", "spark"], "argument --engine: invalid choice: 'spark'"),
        (["--cam_names", "cam_top"], "unknown camera 'cam_top'"),
        (["--episode_len", "0"], "--episode_len must be in 1 .. 100000"),
        (["--num_episodes", "0"], "--num_episodes must be in 1 .. 1000000"),
        (["--image_size", "big"], "--image_size must look like"),
        (["--visual", "pretty"], "unknown visual 'pretty'"),
        (["--num_workers", "0"], "--num_workers must be at least 1"),
        (["--ray_address", "auto"], "--ray_address needs --engine ray"),
        (["--engine", "ray", "--onscreen_render"], "--onscreen_render needs --engine local"),
    ],
)
def test_bad_input_is_one_line_exit_2(tmp_path, capsys, extra, needle):
    rc, out, err = _run_cli(["--data_dir", "d", "--root_dir", str(tmp_path), *extra], capsys)
    assert rc == 2 and out == ""
    assert err.startswith("error: ") and needle in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "d").exists()


def test_bad_input_in_a_real_process_is_one_line_exit_2(tmp_path):
    for extra in (["--seed", str(2**64)], ["--episode_len", "1e13"], ["--seed", "-1"]):
        proc = subprocess.run(
            [
                sys.executable,
                "-m",
                "trossen_arm_mujoco.cli",
                "record",
                "--data_dir",
                "d",
                "--root_dir",
                str(tmp_path),
                *extra,
            ],
            capture_output=True,
            text=True,
            cwd=REPO,
            timeout=120,
        )
        assert proc.returncode == 2 and proc.stdout == ""
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr


def test_help_names_the_subcommand():
    proc = subprocess.run(
        [sys.executable, "-m", "trossen_arm_mujoco.cli", "record", "--help"],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    assert proc.returncode == 0
    assert proc.stdout.startswith("usage: trossen-mujoco record ")
    assert "--wait" in proc.stdout


def test_too_many_workers_are_capped_at_the_cpus(tmp_path, capsys):
    cpus = available_cpus()
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), *SUCCEEDS, "--num_workers", "100000"]
    rc, _, err = _run_cli(args, capsys)
    assert rc == 0
    assert err.splitlines()[0] == (
        f"warning: --num_workers 100000 is more than the {cpus} CPUs of this machine; using {cpus}"
    )


def test_no_shadows_and_menagerie_visual(tmp_path, capsys, fake_menagerie):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "3"]
    args += ["--cam_names", "cam_high", "--image_size", "12x16"]
    rc, _, err = _run_cli([*args, "--no_shadows", "--visual", "menagerie"], capsys)
    assert rc == 1, err  # 3 steps: a failed episode
    ep = load_episode(tmp_path / "d" / "episode_0.hdf5", load_images=True)
    assert ep.attrs["shadows"] == False and ep.attrs["visual"] == "menagerie"  # noqa: E712
    assert ep.images["cam_high"].shape == (3, 12, 16, 3) and ep.images["cam_high"].std() > 0


def test_no_antialias_is_stored_and_a_rerun_without_it_is_refused(tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "3"]
    args += ["--cam_names", "cam_high", "--image_size", "12x16", "--no_antialias"]
    rc, _, err = _run_cli(args, capsys)
    assert rc == 1, err  # 3 steps: a failed episode
    ep = load_episode(tmp_path / "d" / "episode_0.hdf5")
    assert ep.attrs["antialias"] == False and ep.attrs["shadows"] == True  # noqa: E712
    rc, _, err = _run_cli(
        [a for a in args if a != "--no_antialias"] + ["--num_episodes", "2"], capsys
    )
    assert rc == 2 and "--no_antialias set (this run: not set)" in err
    assert len(err.strip().splitlines()) == 1


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
    assert (
        err == "error: the Ray engine needs Ray: "
        'pip install ".[ray]" in the trossen_arm_mujoco checkout\n'
    )


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


def _record_cmd(tmp_path: Path, *extra: str) -> list[str]:
    return [
        sys.executable,
        "trossen_arm_mujoco/scripts/record_sim_episodes.py",
        "--data_dir",
        "d",
        "--root_dir",
        str(tmp_path),
        *SUCCEEDS,
        *extra,
    ]


def _start(cmd: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        cmd,
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_sigint,
    )


def _wait_for(path: Path, proc: subprocess.Popen, timeout: float = 240) -> None:
    deadline = time.time() + timeout
    while not path.exists():
        assert proc.poll() is None, proc.communicate()
        assert time.time() < deadline, f"{path} never appeared"
        time.sleep(0.02)


def _temp_files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob(".*"))


def test_sigint_keeps_finished_episodes_and_restart_completes(tmp_path):
    data = tmp_path / "d"
    cmd = _record_cmd(tmp_path, "--num_episodes", "4")
    proc = _start(cmd)
    _wait_for(data / "episode_1.hdf5", proc)
    time.sleep(0.3)  # inside episode 2
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted (Ctrl-C)" in err and "Traceback" not in err
    kept = [k for k, _ in list_episodes(data)]
    assert kept[:2] == [0, 1] and len(kept) < 4
    assert sorted(os.listdir(data)) == [f"episode_{k}.hdf5" for k in kept]  # no temp, no lock
    for k in kept:
        assert load_episode(data / f"episode_{k}.hdf5").num_steps == 440
    done = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=240)
    assert done.returncode == 0, done.stderr
    assert f"continuing the dataset in {data}: keeping episodes 0..{kept[-1]}" in done.stdout
    assert [k for k, _ in list_episodes(data)] == [0, 1, 2, 3]
    assert load_episode(data / "episode_3.hdf5").attrs["attempt"] == 3


def test_sigterm_with_workers_publishes_finished_episodes_and_leaves_no_temp_file(tmp_path):
    data = tmp_path / "d"
    proc = _start(_record_cmd(tmp_path, "--num_episodes", "6", "--num_workers", "2"))
    _wait_for(data / "episode_0.hdf5", proc)
    deadline = time.time() + 60
    while not list((data / ".staging").glob(".attempt_*.tmp")):  # a worker is writing
        assert time.time() < deadline and proc.poll() is None
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert "Traceback" not in err
    kept = [k for k, _ in list_episodes(data)]
    assert 0 in kept and len(kept) < 6
    assert f"{len(kept)} finished episode(s) kept in {data}" in err
    assert _temp_files(data) == []  # no temp file, no staging, no lock file
    assert sorted(os.listdir(data)) == [f"episode_{k}.hdf5" for k in kept]
    for k in kept:
        assert load_episode(data / f"episode_{k}.hdf5").attrs["success"]


def test_a_second_run_on_the_folder_refuses_or_waits(tmp_path):
    """Two real record processes on one folder: the second refuses with the first one's pid;
    with --wait it waits, then continues the dataset the first one left."""
    data = tmp_path / "d"
    first = _start(_record_cmd(tmp_path, "--num_episodes", "4"))  # long enough
    _wait_for(data / ".trossen.lock", first)
    while True:  # the holder writes its pid once it holds the lock
        text = (data / ".trossen.lock").read_text()
        if text or first.poll() is not None:
            break
        time.sleep(0.02)
    second = subprocess.run(
        _record_cmd(tmp_path, "--num_episodes", "2"),
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert second.returncode == 2 and second.stdout == ""
    assert second.stderr == (
        f"error: another record run (pid {first.pid}) is writing to {data}; wait for it to "
        "finish (or pass --wait), or choose another --data_dir\n"
    )
    assert first.poll() is None, "the first run ended before the second one was refused"
    waiting = _start(_record_cmd(tmp_path, "--num_episodes", "5", "--wait"))
    out, err = first.communicate(timeout=240)
    assert first.returncode == 0, err
    assert out.strip().splitlines()[-1] == "Success: 4 / 4"
    out, err = waiting.communicate(timeout=240)
    assert waiting.returncode == 0, err
    assert err.splitlines()[0] == (
        f"waiting for the record run (pid {first.pid}) writing to {data} to finish "
        "(Ctrl-C to stop waiting)"
    )
    assert f"continuing the dataset in {data}: keeping episodes 0..3" in out
    assert out.strip().splitlines()[-1] == "Success: 1 / 1"
    assert sorted(os.listdir(data)) == [f"episode_{k}.hdf5" for k in range(5)]


def test_a_rerun_cleans_what_a_killed_run_left(tmp_path):
    """SIGKILL leaves a temporary file and the lock file; the next run (the lock's holder is
    gone) removes them and continues."""
    data = tmp_path / "d"
    proc = _start(_record_cmd(tmp_path, "--num_episodes", "3"))
    _wait_for(data / "episode_0.hdf5", proc)
    deadline = time.time() + 60
    while not list(data.glob(".episode_1.hdf5.*.tmp")):
        assert time.time() < deadline and proc.poll() is None
        time.sleep(0.02)
    proc.kill()
    proc.communicate()
    left = _temp_files(data)
    assert ".trossen.lock" in left and any(name.startswith(".episode_1.hdf5.") for name in left)
    done = subprocess.run(
        _record_cmd(tmp_path, "--num_episodes", "2"),
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert done.returncode == 0, done.stderr
    assert sorted(os.listdir(data)) == ["episode_0.hdf5", "episode_1.hdf5"]


def test_trossen_mujoco_record_dispatch_and_progress_off_a_terminal(tmp_path):
    """Piped output (not a terminal): no redrawn bar (no carriage returns), at most one
    progress line every few seconds instead of one per step."""
    start = time.monotonic()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "trossen_arm_mujoco.cli",
            "record",
            "--data_dir",
            "d",
            "--root_dir",
            str(tmp_path),
            "--num_episodes",
            "2",
            "--episode_len",
            "300",
            "--cam_names",
            "none",
        ],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=120,
    )
    wall = time.monotonic() - start
    assert proc.returncode == 1, proc.stderr  # 300 steps: both episodes fail
    assert proc.stdout.strip().splitlines()[-1].startswith("Success: 0 / 2; ")
    assert "\r" not in proc.stderr and "\r" not in proc.stdout
    progress = [line for line in proc.stderr.splitlines() if " step (" in line]
    assert len(progress) <= wall / 5 + 1, proc.stderr  # 600 steps recorded


def test_onscreen_render_shows_live_viewer_under_xvfb(tmp_path, xscreen):
    env = {**os.environ, "DISPLAY": xscreen.display, "MUJOCO_GL": "egl"}
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
    deadline = time.time() + 120
    colours = 0
    while time.time() < deadline and proc.poll() is None:
        time.sleep(2.0)
        colours = xscreen.colours(tmp_path / "screen.xwd")
        if colours > 200:
            break
    out, err = proc.communicate(timeout=180)
    assert proc.returncode == 1, err  # 150 steps: the episode fails
    assert "live view off" not in err
    assert colours > 200, f"screenshot looks blank ({colours} colours)"


def test_randomize_flag_stores_the_randomization(tmp_path, capsys):
    from trossen_arm_mujoco.tasks.randomization_record import record_from_json

    args = ["--root_dir", str(tmp_path), "--episode_len", "5", "--cam_names", "none"]
    rc, out, _ = _run_cli(
        ["--data_dir", "r", "--randomize", "--num_workers", "2", "--num_episodes", "2", *args],
        capsys,
    )
    assert rc == 1 and "randomized" in out  # 5 steps: failed episodes, kept
    records = [
        record_from_json(load_episode(tmp_path / "r" / f"episode_{k}.hdf5").attrs["randomization"])
        for k in (0, 1)
    ]
    assert records[0]["version"] == 1 and records[0] != records[1]
    rc, out, _ = _run_cli(["--data_dir", "p", *args], capsys)
    assert rc == 1 and "randomized" not in out
    assert "randomization" not in load_episode(tmp_path / "p" / "episode_0.hdf5").attrs


def test_crop_is_recorded_and_a_resume_with_another_crop_is_refused(tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "3"]
    args += ["--cam_names", "cam_high", "--image_size", "12x16", "--no_shadows"]
    crop = ["--crop", "cam_high:217,243,150,200"]
    rc, _, err = _run_cli([*args, *crop], capsys)
    assert rc == 1, err  # 3 steps: a failed episode
    ep = load_episode(tmp_path / "d" / "episode_0.hdf5", load_images=True)
    assert ep.attrs["crops"] == "cam_high:217,243,150,200"
    assert ep.images["cam_high"].shape == (3, 12, 16, 3)
    rc, _, err = _run_cli([*args, "--num_episodes", "2"], capsys)  # the same, uncropped
    assert rc == 2 and "--crop cam_high:217,243,150,200 (this run: none)" in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("crop", ["cam_high:1,2,3", "cam_high:0,0,500,10", "cam_top:0,0,10,10"])
def test_bad_crop_is_one_line_exit_2(tmp_path, capsys, crop):
    rc, out, err = _run_cli(
        ["--data_dir", "d", "--root_dir", str(tmp_path), "--crop", crop, *FAST], capsys
    )
    assert rc == 2 and out == "", err
    last = err.strip().splitlines()[-1]  # after the warning about the short --episode_len
    assert last.startswith("error: ") and ("--crop" in last or "valid cameras" in last), err
    assert "Traceback" not in err and not (tmp_path / "d").exists()


def test_a_crop_of_a_camera_not_recorded_is_one_line_exit_2(tmp_path, capsys):
    rc, out, err = _run_cli(
        [
            "--data_dir",
            "d",
            "--root_dir",
            str(tmp_path),
            "--cam_names",
            "cam_high",
            "--crop",
            "cam_low:0,0,100,100",
            "--episode_len",
            "20",
        ],
        capsys,
    )
    assert rc == 2 and out == "", err
    last = err.strip().splitlines()[-1]
    assert last == (
        "error: --crop cam_low:0,0,100,100: camera cam_low is not recorded "
        "(cam_high); add it to --cam_names or leave the crop out"
    )
    assert not (tmp_path / "d").exists()


def test_onscreen_render_without_a_display_says_so_once(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    rc, _, err = _run_cli(
        [
            "--data_dir",
            "d",
            "--root_dir",
            str(tmp_path),
            "--num_episodes",
            "2",
            "--onscreen_render",
            *FAST,
        ],
        capsys,
    )
    assert rc == 1, err  # 20 steps: failed episodes, kept
    assert err.count("live view off: no DISPLAY; continuing headless") == 1, err
