"""Episode spools (in this process, no network): every appended step is on disk at once, a
spool left by a dead process is published by :func:`recover_spools` as the folder's next
episode (validated), and one that cannot be is kept with a line, never deleted."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.twin.episode_spool import RECORDING_ID_ATTR, EpisodeSpool
from trossen_arm_mujoco.twin.spool_recovery import read_spool, recover_spools, stale_spools

H, W = 6, 8
ATTRS = {
    "task_name": "sim_transfer_cube",
    "seed": 7,
    "dt": 0.02,
    "source": "serve",
    "initial_env_state": np.arange(7.0),
    "object_names": ["box"],
}


def dead_pid() -> int:
    """The pid of a process that has ended."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def as_dead(spool_path: Path) -> Path:
    """Rename a spool of this process as if a process that ended had left it."""
    target = spool_path.with_name(f".serve_spool.{dead_pid()}-abcd1234.tmp")
    spool_path.rename(target)
    return target


def fill(spool: EpisodeSpool, steps: int, cams: tuple[str, ...] = ("cam_high",)) -> None:
    for t in range(steps):
        images = {c: np.full((H, W, 3), (t * 10 + i) % 256, np.uint8) for i, c in enumerate(cams)}
        spool.append_step(
            np.full(16, 0.01 * t),
            np.zeros(16),
            np.full(16, -0.01 * t),
            float(t >= steps - 1) * 4.0,
            np.arange(7.0) + t,
            images,
        )


def left_spool(folder: Path, steps: int, index: int = 0, **attrs) -> Path:
    """A spool of ``steps`` steps as a killed serve leaves it (never closed, a dead pid)."""
    meta = {
        "index": index,
        "attrs": {**ATTRS, **attrs},
        "compression": "lzf",
        "task_max_reward": 4.0,
    }
    spool = EpisodeSpool(folder, ["cam_high"], H, W, meta=meta)
    fill(spool, steps)
    spool.close()  # what the kernel does for a killed process: the file stays as written
    return as_dead(spool.path)


def next_index(folder: Path):
    def get() -> int:
        found = list_episodes(folder, missing_ok=True)
        return found[-1][0] + 1 if found else 0

    return get


def test_every_step_is_on_disk_as_soon_as_it_is_appended(tmp_path: Path) -> None:
    spool = EpisodeSpool(tmp_path, ["cam_high"], H, W, meta={"attrs": ATTRS})
    fill(spool, 3)
    contents = read_spool(spool.path)  # read while the spool is open, as after a SIGKILL
    assert contents.steps == 3 and contents.meta["attrs"]["seed"] == 7
    np.testing.assert_allclose(contents.rows["qpos"][2], np.full(16, 0.02))
    assert contents.rows["reward"] == [0.0, 0.0, 4.0]
    spool.discard()
    assert not list(tmp_path.iterdir())


def test_a_left_spool_is_published_as_the_next_episode(tmp_path: Path) -> None:
    (tmp_path / "episode_0.hdf5").write_bytes(b"")  # taken: recovery never overwrites
    path = left_spool(tmp_path, 5, index=0)
    with open(path, "ab") as f:  # killed in the middle of a step: the torn step is ignored
        f.write(b"\x00" * 100)
    lines: list[str] = []
    [result] = recover_spools(tmp_path, lambda: 1, lines.append)
    assert result.episode == tmp_path / "episode_1.hdf5" and result.steps == 5
    assert not path.exists()
    assert lines == [
        f"episode_1.hdf5: recovered 5 steps (0.10 s) that a stopped serve left in {path.name}"
    ]
    episode = load_episode(result.episode, load_images=True)
    assert episode.num_steps == 5 and episode.attrs["seed"] == 7
    assert episode.attrs["success"] and episode.attrs["final_reward"] == 4.0
    assert episode.attrs["end_reason"].startswith("recovered")
    assert episode.images["cam_high"][3, 0, 0, 0] == 30
    np.testing.assert_allclose(episode.env_state[4], np.arange(7.0) + 4)


def test_a_spool_whose_episode_was_published_is_removed(tmp_path: Path) -> None:
    meta = {"index": 0, "attrs": {**ATTRS, RECORDING_ID_ATTR: "r1"}}
    spool = EpisodeSpool(tmp_path, ["cam_high"], H, W, meta=meta)
    fill(spool, 2)
    copy = tmp_path / ".copy"
    copy.write_bytes(spool.path.read_bytes())
    spool.publish(
        tmp_path / "episode_0.hdf5", {**ATTRS, RECORDING_ID_ATTR: "r1", "success": False}, "lzf"
    )
    left = as_dead(copy)  # as if killed between the publish and the unlink
    assert recover_spools(tmp_path, next_index(tmp_path), print)[0].episode is None
    assert not left.exists() and [i for i, _ in list_episodes(tmp_path)] == [0]


def test_a_spool_that_cannot_be_published_is_kept_with_a_line(tmp_path: Path) -> None:
    path = left_spool(tmp_path, 3)
    data = bytearray(path.read_bytes())
    data[:4] = b"JUNK"
    path.write_bytes(bytes(data))
    lines: list[str] = []
    [result] = recover_spools(tmp_path, next_index(tmp_path), lines.append)
    assert result.episode is None and path.exists()
    assert len(lines) == 1 and str(path) in lines[0] and "is kept, not recovered" in lines[0]
    assert not list(tmp_path.glob("episode_*"))


def test_spools_of_running_processes_and_empty_ones(tmp_path: Path) -> None:
    mine = EpisodeSpool(tmp_path, ["cam_high"], H, W)  # this process runs: not stale
    fill(mine, 1)
    empty = as_dead(EpisodeSpool(tmp_path, ["cam_high"], H, W).path)  # nothing recorded
    assert stale_spools(tmp_path) == [empty]
    assert recover_spools(tmp_path, next_index(tmp_path), print)[0].steps == 0
    assert not empty.exists() and mine.path.exists()
    mine.discard()


def test_a_failed_publish_keeps_a_named_spool(tmp_path: Path) -> None:
    spool = EpisodeSpool(tmp_path, ["cam_high"], H, W, meta={"index": 0, "attrs": ATTRS})
    fill(spool, 2)
    (tmp_path / "episode_0.hdf5").write_bytes(b"taken")
    with pytest.raises(Exception, match="refusing to overwrite"):
        spool.publish(tmp_path / "episode_0.hdf5", {**ATTRS, "success": False}, "lzf")
    assert spool.path is not None and spool.path.exists()
    assert read_spool(spool.path).steps == 2


def test_an_anonymous_spool_has_no_name(tmp_path: Path) -> None:
    spool = EpisodeSpool(tmp_path, ["cam_high"], H, W, anonymous=True)
    fill(spool, 2)
    assert spool.path is None and not list(tmp_path.iterdir())
    spool.publish(tmp_path / "episode_0.hdf5", {**ATTRS, "success": False}, "none")
    assert load_episode(tmp_path / "episode_0.hdf5", load_images=True).num_steps == 2
    no_cams = EpisodeSpool(tmp_path, [], H, W, anonymous=True)
    fill(no_cams, 1, ())
    assert len(no_cams) == 1 and sorted(os.listdir(tmp_path)) == ["episode_0.hdf5"]
    no_cams.discard()


def test_a_spool_of_the_older_format_is_kept_and_explained(tmp_path: Path) -> None:
    import h5py

    path = tmp_path / f".serve_spool.{dead_pid()}-0a1b2c3d.tmp"
    with h5py.File(path, "w") as f:  # what versions before this one spooled: frames only
        f.create_dataset("cam_high", data=np.zeros((3, H, W, 3), np.uint8))
    lines: list[str] = []
    [result] = recover_spools(tmp_path, next_index(tmp_path), lines.append)
    assert result.episode is None and path.exists()
    assert len(lines) == 1 and "older version" in lines[0] and "move it out" in lines[0]
