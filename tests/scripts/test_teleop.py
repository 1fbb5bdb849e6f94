"""``trossen-mujoco teleop``: served leader arms (replaying a scripted episode) drive the
simulated followers through the unmodified ``trossen_arm`` driver on both sides.

Loopback addresses 127.0.0.71 .. 127.0.0.79 (the allocation is in ``tests/twin/conftest.py``).
The teleop runs are subprocesses (their own signals and exit status); the leader pairs run in
this process's threads.
"""

from __future__ import annotations

import io
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.collect.pipeline import episode_seed
from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.scripts.record_sim_episodes import cli as record_cli
from trossen_arm_mujoco.scripts.teleop import StdinControl
from trossen_arm_mujoco.scripts.teleop import cli as teleop_cli

pytest.importorskip("trossen_arm")
pytest.importorskip("trossen_arm_sim")

from trossen_arm_mujoco.twin.leader_trajectory import load_leader_trajectory  # noqa: E402
from trossen_arm_mujoco.twin.leaders import LeaderPair  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
SEED = 7
#: The arm joints of the 16-value rows (fingers left out).
ARM = np.r_[0:6, 8:14]


@pytest.fixture(scope="module")
def source(tmp_path_factory) -> Path:
    """A scripted transfer episode (440 steps, 8.8 s, no images) recorded with --seed 7."""
    root = tmp_path_factory.mktemp("teleop_source")
    args = [
        "--root_dir",
        str(root),
        "--data_dir",
        "src",
        "--episode_len",
        "440",
        "--cam_names",
        "none",
        "--seed",
        str(SEED),
    ]
    assert record_cli(args) == 0
    return root / "src" / "episode_0.hdf5"


@contextmanager
def leaders(path: Path, left: str, right: str, lead_in: float = 0.5) -> Iterator[LeaderPair]:
    with LeaderPair(load_leader_trajectory(path), left, right, lead_in=lead_in) as pair:
        yield pair


def teleop_args(root: Path, left: str, right: str, *extra: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "trossen_arm_mujoco.cli",
        "teleop",
        "--leader_left_ip",
        left,
        "--leader_right_ip",
        right,
        "--root_dir",
        str(root),
        "--data_dir",
        "tele",
        "--cam_names",
        "none",
        *extra,
    ]


def env() -> dict[str, str]:
    return {**os.environ, "MUJOCO_GL": "egl", "PYTHONUNBUFFERED": "1"}


def other_lines(stderr: str) -> list[str]:
    """stderr without the slow-loop warnings (a busy test machine may give them)."""
    return [line for line in stderr.splitlines() if not line.startswith("warning: episode")]


def test_teleop_follows_the_served_leaders_and_transfers_the_cube(source, tmp_path):
    with leaders(source, "127.0.0.71", "127.0.0.72") as pair:
        proc = subprocess.run(
            teleop_args(
                tmp_path, "127.0.0.71", "127.0.0.72", "--seed", str(SEED), "--episode_len", "500"
            ),
            stdin=subprocess.DEVNULL,
            capture_output=True,
            text=True,
            timeout=150,
            cwd=REPO,
            env=env(),
        )
        assert pair.finished.is_set()
    assert proc.returncode == 0, proc.stderr
    assert other_lines(proc.stderr) == []
    out = proc.stdout.splitlines()
    assert out[1] == "episode 0: recording"
    assert out[2].startswith(
        "episode 0: 500 steps (ended by episode len), reward 4 (max 4 of 4), success; "
    )
    assert out[-1].startswith("recorded 1 episode(s); Success: 1 / 1; ")
    ep, src = load_episode(tmp_path / "tele" / "episode_0.hdf5"), load_episode(source)
    attrs = ep.attrs
    # the scene of record's episode 0 with the same seed: the same cube pose
    assert attrs["seed"] == src.attrs["seed"] == episode_seed(SEED, 0)
    np.testing.assert_array_equal(ep.box_pose, src.box_pose)
    assert attrs["success"] and attrs["real_replay_checked"] and attrs["teleop"]
    assert ep.reward[-1] == 4 and ep.num_steps == 500 and attrs["dt"] == pytest.approx(0.02)
    assert list(attrs["leader_ips"]) == ["127.0.0.71", "127.0.0.72"]
    # the followers track the commands (the leaders' poses, speed-limited) after the ramp
    ramp = attrs["ramp_steps"]
    assert 0 <= ramp <= 5
    err = ep.qpos[ramp + 1 :, ARM] - ep.action[ramp:-1, ARM]
    rms = float(np.sqrt(np.mean(err**2)))
    assert rms < 0.05 and attrs["tracking_rms_rad"] < 0.05
    lags = [
        np.sqrt(np.mean((ep.qpos[ramp + k :, ARM] - ep.action[ramp : ep.num_steps - k, ARM]) ** 2))
        for k in range(1, 6)
    ]
    assert int(np.argmin(lags)) + 1 <= 4  # the followers reach a command within 60 ms
    # the commands are the leaders' poses: each lies on the source episode's path ...
    path = np.concatenate(
        [
            np.linspace(a, b, 4, endpoint=False)
            for a, b in zip(src.action[:-1, ARM], src.action[1:, ARM], strict=True)
        ]
    )
    off = np.array([np.min(np.linalg.norm(path - row, axis=1)) for row in ep.action[:, ARM]])
    assert float(np.sqrt(np.mean(off**2))) < 0.02, off.max()
    # ... and the leaders' whole replay was recorded, up to its last pose (held)
    np.testing.assert_allclose(ep.action[-1, ARM], src.action[-1, ARM], atol=2e-3)
    print(
        f"tracking RMS {rms:.4f} rad, best lag {int(np.argmin(lags)) + 1} steps, "
        f"{attrs['achieved_fps']:.1f} Hz, {attrs['speed_limited_values']} speed-limited"
    )


class Lines:
    """A subprocess's stdout lines, read in a thread (waits with a deadline)."""

    def __init__(self, stream) -> None:
        self.seen: list[str] = []
        self._queue: queue.Queue[str | None] = queue.Queue()
        threading.Thread(target=self._read, args=(stream,), daemon=True).start()

    def _read(self, stream) -> None:
        for line in stream:
            self._queue.put(line.rstrip("\n"))
        self._queue.put(None)

    def wait_for(self, start: str, timeout: float = 60.0) -> str:
        deadline = time.monotonic() + timeout
        while True:
            try:
                line = self._queue.get(timeout=max(0.0, deadline - time.monotonic()))
            except queue.Empty:
                raise AssertionError(f"no line starting {start!r}; saw {self.seen}") from None
            if line is None:
                raise AssertionError(f"stdout closed before {start!r}; saw {self.seen}")
            self.seen.append(line)
            if line.startswith(start):
                return line


def start_teleop(root: Path, *extra: str) -> tuple[subprocess.Popen, Lines]:
    proc = subprocess.Popen(
        teleop_args(root, "127.0.0.73", "127.0.0.74", *extra),
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=REPO,
        env=env(),
    )
    return proc, Lines(proc.stdout)


def no_temp_files(folder: Path) -> bool:
    return not [p for p in folder.iterdir() if p.name.startswith(".") and "tmp" in p.name]


def test_keys_discard_and_end_episodes_and_sigterm_keeps_finished_ones(source, tmp_path):
    folder = tmp_path / "tele"
    folder.mkdir()
    shutil.copy(source, folder / "episode_0.hdf5")  # an existing episode: never touched
    before = (folder / "episode_0.hdf5").read_bytes()
    with leaders(source, "127.0.0.73", "127.0.0.74"):
        proc, out = start_teleop(
            tmp_path,
            "--seed",
            "3",
            "--episode_len",
            "150",
            "--num_episodes",
            "3",
            "--object_poses_from",
            str(source),
        )
        try:
            out.wait_for("episode 1: recording")  # numbering continues after episode 0
            proc.stdin.write("d\n")
            proc.stdin.flush()
            assert out.wait_for("episode 1: ") == "episode 1: discarded"
            out.wait_for("episode 1: recording")  # the same number again
            time.sleep(0.6)
            proc.stdin.write("e\n")
            proc.stdin.flush()
            kept = out.wait_for("episode 1: ")
            out.wait_for("episode 2: recording")
            time.sleep(0.3)
            proc.send_signal(signal.SIGTERM)
            _, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 143, err
    assert other_lines(err) == [
        f"interrupted (SIGTERM): episode 2 in progress discarded; 1 new episode(s) kept; "
        f"dataset: episodes 0..1 in {folder}"
    ]
    assert "(ended by operator)" in kept
    assert [k for k, _ in list_episodes(folder)] == [0, 1]
    assert (folder / "episode_0.hdf5").read_bytes() == before
    ep = load_episode(folder / "episode_1.hdf5")
    assert ep.attrs["ended_by"] == "operator" and 10 < ep.num_steps < 150
    assert ep.attrs["seed"] == episode_seed(3, 1) and ep.attrs["base_seed"] == 3
    np.testing.assert_array_equal(ep.box_pose, load_episode(source).box_pose)
    assert no_temp_files(folder)


def test_a_leader_that_fails_mid_episode_ends_the_run_in_one_line(source, tmp_path):
    folder = tmp_path / "tele"
    with leaders(source, "127.0.0.73", "127.0.0.74") as pair:
        proc, out = start_teleop(tmp_path, "--episode_len", "60", "--num_episodes", "4")
        try:
            out.wait_for("episode 0: 60 steps")
            out.wait_for("episode 1: recording")
            time.sleep(0.3)
            pair.stop()  # both controllers vanish mid-episode
            _, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
    assert proc.returncode == 1, err
    lines = other_lines(err)
    assert len(lines) == 1, err
    assert lines[0].startswith("error: ") and " leader arm (127.0.0." in lines[0]
    assert lines[0].endswith(
        f"; episode 1 in progress discarded; 1 new episode(s) kept; dataset: episode 0 in {folder}"
    )
    assert [k for k, _ in list_episodes(folder)] == [0]
    assert load_episode(folder / "episode_0.hdf5").num_steps == 60
    assert no_temp_files(folder)


def test_no_leader_there_is_one_line(tmp_path, capsys):
    rc = teleop_cli(
        [
            "--leader_left_ip",
            "127.0.0.75",
            "--leader_right_ip",
            "127.0.0.76",
            "--root_dir",
            str(tmp_path),
            "--data_dir",
            "d",
            "--cam_names",
            "none",
            "--connect_timeout",
            "1",
        ]
    )
    out, err = capsys.readouterr()
    assert rc == 1
    assert err.startswith("error: cannot connect to the left leader arm at 127.0.0.75: ")
    assert err.count("\n") == 1 and "serve --role leader" in err
    assert list_episodes(tmp_path / "d") == []


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--task_name", "reach"], "unknown kit task 'reach'; valid kit tasks: "),
        (
            ["--task_name", "mobile_pick_place"],
            "unknown kit task 'mobile_pick_place'; valid kit tasks: ",
        ),
        (["--episode_len", "0"], "--episode_len must be in 1 .. "),
        (["--cam_names", "cam_top"], "unknown camera 'cam_top'"),
        (["--end_effector", "wxai_v0_gripper"], "unknown end effector 'wxai_v0_gripper'"),
        (["--object_poses_from", "missing.hdf5"], "episode file not found"),
    ],
)
def test_bad_flags_are_one_line(args, match, tmp_path, capsys):
    base = [
        "--leader_left_ip",
        "127.0.0.75",
        "--leader_right_ip",
        "127.0.0.76",
        "--root_dir",
        str(tmp_path),
        "--data_dir",
        "d",
    ]
    assert teleop_cli([*base, *args]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and match in err and err.count("\n") == 1
    if "valid kit tasks" in match:  # the Stationary AI kit's tasks (installed ones too)
        assert "sim_insertion, sim_transfer_cube" in err and "mobile_pick_place," not in err


def test_stdin_control_keys():
    control = StdinControl(io.StringIO("x\nd\n"))
    time.sleep(0.1)
    assert not control.interactive and control.wait_start(0)
    assert control.poll() == "discard" and control.poll() is None
    control = StdinControl(io.StringIO("E\n"))
    time.sleep(0.1)
    assert control.poll() == "end"


class FakeViewer:
    """Stands in for ``LiveViewer``: counts redraws and closes."""

    def __init__(self) -> None:
        self.updates, self.closed, self.opened_with = 0, False, None

    def update(self, images=None) -> bool:
        self.updates += 1
        return True

    def close(self) -> None:
        self.closed = True


def test_viewer_is_opened_once_redrawn_every_step_and_closed(source, tmp_path, monkeypatch):
    """``--viewer``: the live view opens at the first step on the follower world, redraws
    after every step and closes at the end. (The real window is shown under Xvfb by the
    record, serve and demo viewer tests, which share ``LiveViewer``.)"""
    from trossen_arm_mujoco import viewer as viewer_module

    fake = FakeViewer()

    def open_viewer(model, data):
        assert fake.opened_with is None, "opened twice"
        fake.opened_with = (model.nbody, data.qpos.shape)
        return fake

    monkeypatch.setattr(viewer_module.LiveViewer, "open", staticmethod(open_viewer))
    with leaders(source, "127.0.0.77", "127.0.0.78"):
        rc = teleop_cli(
            [
                "--leader_left_ip",
                "127.0.0.77",
                "--leader_right_ip",
                "127.0.0.78",
                "--root_dir",
                str(tmp_path),
                "--data_dir",
                "tele",
                "--cam_names",
                "none",
                "--episode_len",
                "40",
                "--viewer",
            ]
        )
    assert rc == 0
    episode = load_episode(tmp_path / "tele" / "episode_0.hdf5")
    assert episode.num_steps == 40 and fake.updates == 40 and fake.closed
    nbody, qpos_shape = fake.opened_with  # the kit world: both arms and the cube
    assert nbody > 20 and qpos_shape[0] > episode.qpos.shape[1]
