"""``trossen-mujoco eval``: a scripted run writes eval_info.json; every user mistake is one
``error:`` line on stderr, exit status 2, no traceback."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from trossen_arm_mujoco import cli

REPO = Path(__file__).resolve().parents[2]
#: A checkpoint config trained on cam_low at 48x64, 14-value actions.
FAKE_CONFIG = {
    "type": "act",
    "input_features": {"observation.images.cam_low": {"type": "VISUAL", "shape": [3, 48, 64]}},
    "output_features": {"action": {"type": "ACTION", "shape": [14]}},
}


def _eval(args, capsys):
    rc = cli.main(["eval", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def _one_error_line(err: str) -> str:
    """The only ``error:`` line of ``err`` (the progress bar may have drawn before it)."""
    assert "Traceback" not in err, err
    errors = [line for line in err.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, err
    assert errors[0].count("error:") == 1 and "\n" not in errors[0]
    return errors[0]


def test_scripted_run_writes_eval_info(tmp_path, capsys):
    out_dir = tmp_path / "eval"
    rc, out, err = _eval(
        [
            "--policy",
            "scripted",
            "--task_name",
            "sim_transfer_cube",
            "--num_episodes",
            "2",
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text(encoding="utf-8"))
    agg = info["aggregated"]
    assert agg["pc_success"] == 100.0 and agg["n_episodes"] == 2
    assert agg["stages"] == {"touched": 100.0, "lifted": 100.0, "transferred": 100.0}
    assert [e["seed"] for e in info["per_episode"]] == [0, 1]
    assert all(e["stages"]["transferred"] for e in info["per_episode"])
    assert info["run"]["layout"] == "kit14" and info["run"]["cam_names"] == []
    lines = out.strip().splitlines()
    assert lines[0].startswith("sim_transfer_cube: 2/2 succeeded, 100.0% (95% CI 34.2-100.0)")
    assert "stages: touched 100%, lifted 100%, transferred 100%" in lines[0]
    assert lines[1].startswith("arm controller checks: on, 0 faults; fastest asked: ")
    assert lines[2].startswith("sim-only: the scripted policy plans from the objects' exact")
    assert lines[3] == f"wrote {out_dir / 'eval_info.json'}"
    assert "error" not in err
    assert sorted(p.name for p in out_dir.iterdir()) == ["eval_info.json", "rollouts.json"]


BAD_INPUTS = {
    "unknown task": (["--task_name", "sim_nope"], "unknown task 'sim_nope'; valid tasks:"),
    "task without a scripted policy": (
        ["--task_name", "reach"],
        "task 'reach' has no scripted policy",
    ),
    "unknown camera": (["--cam_names", "cam_nope"], "unknown camera 'cam_nope'; valid cameras:"),
    "bad image size": (["--image_size", "48by64"], "image size must look like HxW"),
    "zero image size": (["--image_size", "0x64"], "image size must look like HxW"),
    "no episode": (["--num_episodes", "0"], "--num_episodes must be in [1, 100000], got 0"),
    "negative seed": (["--seed", "-1"], "--seed must be in [0, 2**63 - 1 - num_episodes]"),
    "too many videos": (["--num_episodes", "1", "--videos", "2"], "--videos must be in"),
    "no worker": (["--num_workers", "0"], "--num_workers must be at least 1, got 0"),
    "bad fps": (["--fps", "0"], "fps must be a number in [1, 500]"),
    "bad length": (["--episode_length", "0"], "episode_length must be in [1, 100000]"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_inputs_are_one_error_line(case, tmp_path, capsys):
    args, expected = BAD_INPUTS[case]
    out_dir = tmp_path / "eval"
    rc, out, err = _eval(["--policy", "scripted", "--output_dir", str(out_dir), *args], capsys)
    assert rc == 2
    assert expected in _one_error_line(err)
    assert not (out_dir / "eval_info.json").exists()


def test_missing_checkpoint_folder(tmp_path, capsys):
    rc, _, err = _eval(
        ["--policy", str(tmp_path / "nowhere"), "--output_dir", str(tmp_path / "eval")], capsys
    )
    assert rc == 2
    assert "no such checkpoint folder" in _one_error_line(err)


def test_folder_without_config_json(tmp_path, capsys):
    folder = tmp_path / "ckpt"
    (folder / "pretrained_model").mkdir(parents=True)
    rc, _, err = _eval(["--policy", str(folder), "--output_dir", str(tmp_path / "eval")], capsys)
    assert rc == 2
    assert "holds no LeRobot checkpoint (no config.json" in _one_error_line(err)


def test_unreadable_config_json(tmp_path, capsys):
    folder = tmp_path / "ckpt"
    folder.mkdir()
    (folder / "config.json").write_text("{not json", encoding="utf-8")
    rc, _, err = _eval(["--policy", str(folder), "--output_dir", str(tmp_path / "eval")], capsys)
    assert rc == 2
    assert "cannot read its config.json" in _one_error_line(err)


def _fake_checkpoint(tmp_path: Path) -> Path:
    folder = tmp_path / "ckpt" / "pretrained_model"
    folder.mkdir(parents=True)
    (folder / "config.json").write_text(json.dumps(FAKE_CONFIG), encoding="utf-8")
    return folder.parent  # the checkpoint step folder: its pretrained_model is found


def test_checkpoint_with_other_features(tmp_path, capsys):
    """Checked against the env before LeRobot is needed and before any progress bar."""
    ckpt = _fake_checkpoint(tmp_path)
    rc, out, err = _eval(
        [
            "--policy",
            str(ckpt),
            "--image_size",
            "24x32",
            "--num_episodes",
            "2",
            "--num_workers",
            "2",
            "--output_dir",
            str(tmp_path / "eval"),
        ],
        capsys,
    )
    assert rc == 2 and out == ""
    line = _one_error_line(err)
    assert err == line + "\n"
    assert f"--policy {ckpt} was trained on other features than this env offers: " in line
    assert "observation.images.cam_low [3, 48, 64] (the env gives [3, 24, 32])" in line
    assert not (tmp_path / "eval" / "eval_info.json").exists()


def test_checkpoint_that_fits_needs_lerobot(tmp_path, capsys, monkeypatch):
    """The fake checkpoint's features fit the env it infers (cam_low at 48x64, 14 values):
    without LeRobot that is one line saying how to install it (LeRobot hidden from imports
    where it is installed)."""
    monkeypatch.setitem(sys.modules, "lerobot", None)  # import lerobot -> ImportError
    rc, out, err = _eval(
        [
            "--policy",
            str(_fake_checkpoint(tmp_path)),
            "--num_episodes",
            "1",
            "--output_dir",
            str(tmp_path / "eval"),
        ],
        capsys,
    )
    assert rc == 2 and out == ""
    line = _one_error_line(err)
    assert err == line + "\n"
    assert "needs LeRobot" in line and "pip install" in line
    assert not (tmp_path / "eval" / "eval_info.json").exists()


def test_existing_eval_info_needs_overwrite(tmp_path, capsys):
    out_dir = tmp_path / "eval"
    out_dir.mkdir()
    (out_dir / "eval_info.json").write_text('{"kept": true}', encoding="utf-8")
    args = [
        "--policy",
        "scripted",
        "--num_episodes",
        "1",
        "--episode_length",
        "3",
        "--output_dir",
        str(out_dir),
    ]
    rc, _, err = _eval(args, capsys)
    assert rc == 2
    line = _one_error_line(err)
    assert line == (
        f"error: {out_dir / 'eval_info.json'} exists; choose another --output_dir "
        "or pass --overwrite"
    )
    assert json.loads((out_dir / "eval_info.json").read_text()) == {"kept": True}
    rc, _, err = _eval([*args, "--overwrite"], capsys)
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    assert info["aggregated"]["n_episodes"] == 1 and info["per_episode"][0]["steps"] == 3


def test_output_dir_that_is_a_file(tmp_path, capsys):
    target = tmp_path / "file"
    target.write_text("x")
    rc, _, err = _eval(["--policy", "scripted", "--output_dir", str(target)], capsys)
    assert rc == 2
    assert "is a file; give a folder" in _one_error_line(err)


def test_subprocess_exit_status_and_exact_stderr(tmp_path):
    env = {**os.environ, "MUJOCO_GL": "egl"}
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "trossen_arm_mujoco.cli",
            "eval",
            "--policy",
            "scripted",
            "--task_name",
            "reach",
            "--output_dir",
            str(tmp_path / "eval"),
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=REPO,
        timeout=120,
    )
    assert done.returncode == 2
    assert done.stdout == ""
    # the single arm's reach is evaluated (eval.arm_env) but has no scripted policy
    assert done.stderr == "error: task 'reach' has no scripted policy\n"
    assert not (tmp_path / "eval").exists()


def test_a_full_disk_writes_no_half_result_and_says_so_in_one_line(tmp_path, capsys, monkeypatch):
    """eval_info.json and rollouts.json are written both or neither: a disk that fills up
    on the second leaves neither, and the run ends with one line (exit 2)."""
    import errno

    real_write = Path.write_text

    def full(self, data, *args, **kwargs):
        if "rollouts.json" in self.name:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_write(self, data, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", full)
    out_dir = tmp_path / "eval"
    rc, _, err = _eval(
        [
            "--policy",
            "scripted",
            "--num_episodes",
            "1",
            "--episode_length",
            "5",
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    line = _one_error_line(err)
    assert rc == 2 and "No space left on device" in line and "MB free" in line
    assert "nothing of this run's results was written" in line
    assert list(out_dir.iterdir()) == []  # no eval_info.json, no temporary file
