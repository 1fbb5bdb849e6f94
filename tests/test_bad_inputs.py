"""Every command-line tool over a table of bad inputs: exit 2, one ``error:`` line on stderr
(naming the flag at fault, where ``EXPECTED`` says), no traceback, no temp file left. Each
case runs ``python -m trossen_arm_mujoco.cli`` in a fresh process, in an empty folder that
also holds an existing episode, a plain file, a symlink loop, a dangling link and a dataset
folder whose ``episode_0.hdf5`` is a folder."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from trossen_arm_mujoco.data.writer import EpisodeWriter

#: (subcommand and flags; {ep} = an episode file, {dir} = its folder, {file} = a plain file)
CASES: list[list[str]] = [
    ["record", "--task_name", "no_such_task", "--num_episodes", "1"],
    ["record", "--seed", "-1", "--num_episodes", "1", "--data_dir", "{tmp}/r"],
    ["record", "--seed", str(2**64), "--num_episodes", "1", "--data_dir", "{tmp}/r"],
    ["record", "--episode_len", "1e13", "--num_episodes", "1", "--data_dir", "{tmp}/r"],
    ["record", "--cam_names", "no_cam", "--num_episodes", "1", "--data_dir", "{tmp}/r"],
    ["record", "--image_size", "0x0", "--num_episodes", "1", "--data_dir", "{tmp}/r"],
    ["visualize", "--data_dir", "{tmp}/missing"],
    ["visualize", "--data_dir", "{dir}", "--output_dir", "{file}"],
    ["visualize", "--data_dir", "{dir}", "--fps", "0"],
    ["export", "--data_dir", "{tmp}/missing", "--output", "{tmp}/o", "--repo_id", "a/b"],
    ["export", "--data_dir", "{dir}", "--output", "{tmp}/o", "--repo_id", "not a repo"],
    ["export", "--data_dir", "{dir}", "--output", "{tmp}/o", "--repo_id", "a/b", "--fps", "0"],
    ["export", "--data_dir", "{dir}", "--output", "{file}", "--repo_id", "a/b"],
    ["replay-real", "--episode", "{tmp}/missing.hdf5", "--backend", "sim"],
    ["replay-real", "--episode", "{ep}", "--backend", "sim", "--fps", "1e-9"],
    ["eval", "--policy", "scripted", "--task_name", "reach", "--num_episodes", "1"],
    ["eval", "--policy", "scripted", "--num_episodes", "0"],
    ["eval", "--policy", "{tmp}/no_checkpoint", "--num_episodes", "1"],
    ["eval", "--policy", "scripted", "--cam_names", "no_cam", "--num_episodes", "1"],
    ["eval", "--policy", "scripted", "--image_size", "axb", "--num_episodes", "1"],
    ["no-such-subcommand"],
    # outputs that cannot be written: refused before any work (tests/test_output_checks.py)
    ["record", "--data_dir", "{file}", "--num_episodes", "1"],
    ["record", "--data_dir", "{loop}", "--num_episodes", "1"],
    ["record", "--data_dir", "{dangling}", "--num_episodes", "1"],
    ["record", "--root_dir", "{file}/sub", "--data_dir", "d", "--num_episodes", "1"],
    ["record", "--data_dir", "{tmp}/eps_dir", "--num_episodes", "1", "--cam_names", "none"],
    ["export", "--data_dir", "{dir}", "--output", "{file}/sub", "--repo_id", "a/b"],
    ["export", "--data_dir", "{dir}", "--output", "{loop}", "--repo_id", "a/b"],
    ["visualize", "--data_dir", "{dir}", "--output_dir", "{file}/sub"],
    ["visualize", "--data_dir", "{dir}", "--output_dir", "{dangling}"],
]

#: Per case (by its first words), text its error line must hold: the flag at fault, and
#: what is wrong with it.
EXPECTED: dict[tuple[str, ...], tuple[str, ...]] = {
    ("record", "--data_dir", "{file}"): ("--data_dir", "is a file"),
    ("record", "--data_dir", "{loop}"): ("--data_dir", "symlink loop"),
    ("record", "--data_dir", "{dangling}"): ("--data_dir", "link to a missing path"),
    ("record", "--root_dir", "{file}/sub"): ("--root_dir", "a file is in the way"),
    ("record", "--data_dir", "{tmp}/eps_dir"): ("--data_dir", "is a folder, not an episode"),
    ("export", "--data_dir", "{dir}", "--output", "{file}/sub"): ("--output", "in the way"),
    ("export", "--data_dir", "{dir}", "--output", "{loop}"): ("--output", "symlink loop"),
    ("visualize", "--data_dir", "{dir}", "--output_dir", "{file}/sub"): ("--output_dir",),
    ("visualize", "--data_dir", "{dir}", "--output_dir", "{dangling}"): ("--output_dir",),
}


@pytest.fixture(scope="module")
def place(tmp_path_factory) -> dict[str, str]:
    tmp = tmp_path_factory.mktemp("bad")
    folder = tmp / "eps"
    folder.mkdir()
    ep = folder / "episode_0.hdf5"
    attrs = {"task_name": "sim_transfer_cube", "seed": 0, "success": False}
    with EpisodeWriter(ep, 3, [], 24, 32, attrs=attrs) as w:
        for _ in range(3):
            w.append(
                qpos=[0.0] * 16,
                qvel=[0.0] * 16,
                action=[0.0] * 16,
                reward=0.0,
                env_state=[0.0] * 7,
                images={},
            )
    plain = tmp / "plain.txt"
    plain.write_text("not a folder\n")
    (tmp / "loop").symlink_to(tmp / "loop2")
    (tmp / "loop2").symlink_to(tmp / "loop")
    (tmp / "dangling").symlink_to(tmp / "gone")
    (tmp / "eps_dir" / "episode_0.hdf5").mkdir(parents=True)  # a folder named like an episode
    return {
        "tmp": str(tmp),
        "dir": str(folder),
        "ep": str(ep),
        "file": str(plain),
        "loop": str(tmp / "loop"),
        "dangling": str(tmp / "dangling"),
    }


@pytest.mark.parametrize("case", CASES, ids=lambda c: " ".join(c)[:60])
def test_bad_input_is_one_line(case, place, tmp_path):
    args = [part.format(**place) for part in case]
    before = set(Path(place["tmp"]).rglob("*"))
    env = {**os.environ, "MUJOCO_GL": "egl", "HOME": str(tmp_path)}
    proc = subprocess.run(
        [sys.executable, "-m", "trossen_arm_mujoco.cli", *args],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env=env,
        timeout=120,
    )
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2, (args, proc.returncode, proc.stderr[-2000:])
    assert "Traceback" not in proc.stderr, proc.stderr[-2000:]
    errors = [line for line in lines if line.startswith("error: ")]
    assert len(errors) == 1, proc.stderr
    assert all(
        line.startswith(("error: ", "warning: ", "note: ")) or "%|" in line for line in lines
    ), lines
    for words, parts in EXPECTED.items():
        if tuple(case[: len(words)]) == words:
            assert all(part in errors[0] for part in parts), (parts, errors[0])
            assert "overwrite=True" not in errors[0]  # the Python API's words, not a flag
            if "--root_dir" not in parts:
                assert "--root_dir" not in errors[0], errors[0]
    after = set(Path(place["tmp"]).rglob("*"))
    left = [p for p in after - before if p.name.endswith(".tmp") or ".tmp" in p.name]
    assert not left, left


def test_every_expectation_names_a_case():
    for words in EXPECTED:
        assert any(tuple(case[: len(words)]) == words for case in CASES), words
