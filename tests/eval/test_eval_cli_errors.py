"""``trossen-mujoco eval`` front-door errors (issue 27): an output folder that cannot be written
is refused before the first episode; a policy that raises is one line naming the policy,
episode and step, then its traceback; too many workers is one plain note. And a run writes
``rollouts.json`` and prints its failure summary."""

from __future__ import annotations

import json
import os

import pytest

from trossen_arm_mujoco import cli, processes
from trossen_arm_mujoco.eval import runner
from trossen_arm_mujoco.fileio import PROBE_PREFIX


def _eval(args, capsys):
    rc = cli.main(["eval", *args])
    out = capsys.readouterr()
    return rc, out.out, out.err


def _no_episode(monkeypatch):
    def fail(self, index):
        raise AssertionError("an episode ran")

    monkeypatch.setattr(runner.EpisodeRunner, "run", fail)


@pytest.mark.parametrize("where", ["under_a_file", "proc"])
def test_unwritable_output_dir_is_refused_before_the_first_episode(
    where, tmp_path, capsys, monkeypatch
):
    _no_episode(monkeypatch)
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    target = blocker / "sub" if where == "under_a_file" else "/proc/trossen_eval_out"
    rc, out, err = _eval(["--policy", "scripted", "--output_dir", str(target)], capsys)
    assert rc == 2 and out == ""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"error: cannot write to --output_dir {target}: ")


def test_the_output_dir_probe_writes_and_removes_a_file(tmp_path, capsys, monkeypatch):
    """The check is a real write: a probe file is created in the folder (created for it) and
    removed, and the folder is removed again when the run stops before writing."""
    made = []
    real_open = os.open

    def spy(path, flags, *args, **kwargs):
        if flags & os.O_CREAT:
            made.append(str(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", spy)
    out_dir = tmp_path / "new" / "eval"
    rc, _, err = _eval(
        ["--policy", "no_such_module_for_eval:act", "--output_dir", str(out_dir)], capsys
    )
    assert rc == 2 and "cannot import it" in err
    probes = [p for p in made if os.path.basename(p).startswith(PROBE_PREFIX)]
    assert probes and all(os.path.dirname(p) == str(out_dir) for p in probes)
    assert not any(os.path.exists(p) for p in probes)
    assert not (tmp_path / "new").exists()


@pytest.mark.parametrize("workers", [1, 2])
def test_a_raising_policy_names_the_call_then_shows_its_traceback(workers, tmp_path, capsys):
    out_dir = tmp_path / "eval"
    rc, _, err = _eval(
        [
            "--policy",
            "os:getcwd",
            "--num_episodes",
            "2",
            "--episode_length",
            "3",
            "--num_workers",
            str(workers),
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    assert rc == 1
    lines = err.splitlines()
    first = [i for i, ln in enumerate(lines) if ln.startswith("error:")]
    assert len(first) == 1, err
    assert lines[first[0]].startswith(
        "error: the policy os:getcwd raised TypeError at episode 0 step 0: "
    )
    assert "getcwd() takes no arguments" in lines[first[0]]
    rest = "\n".join(lines[first[0] + 1 :])
    assert "Traceback" in rest and "TypeError" in rest  # the policy's own traceback follows
    assert not (out_dir / "eval_info.json").exists()


def test_too_many_workers_is_one_plain_note(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(processes, "available_cpus", lambda: 1)
    out_dir = tmp_path / "eval"
    rc, out, err = _eval(
        [
            "--policy",
            "os:getcwd",
            "--num_episodes",
            "3",
            "--episode_length",
            "2",
            "--num_workers",
            "1000",
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    notes = [ln for ln in err.splitlines() if ln.startswith("note:")]
    assert notes == ["note: --num_workers 1000 > 1 CPUs; using 1"], err
    assert "Warning" not in err and "warnings.warn" not in err
    assert rc == 1  # it went on with one worker (then os:getcwd raised)


def test_a_run_writes_rollouts_json_and_prints_the_failures(tmp_path, capsys):
    out_dir = tmp_path / "eval"
    rc, out, err = _eval(
        [
            "--policy",
            "scripted",
            "--num_episodes",
            "1",
            "--episode_length",
            "200",
            "--output_dir",
            str(out_dir),
        ],
        capsys,
    )
    assert rc == 0, err
    info = json.loads((out_dir / "eval_info.json").read_text())
    assert set(info["per_episode"][0]) == {
        "episode_ix",
        "seed",
        "sum_reward",
        "max_reward",
        "success",
        "steps",
        "stages",
        "fault",
    }
    report = json.loads((out_dir / "rollouts.json").read_text())
    episode = report["episodes"][0]
    assert episode["stopped"] == {"reached": "lifted", "missed": "transferred"}  # 4 s only
    assert report["aggregated"]["failed_by_stage_reached"] == {"lifted": 1}
    assert out.splitlines()[-1] == (
        f"failed: 1 (furthest stage reached: lifted 1); wrote {out_dir / 'rollouts.json'}"
    )


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--crop", "cam_high:1,2,3"], "--crop must look like CAMERA:TOP,LEFT,HEIGHT,WIDTH"),
    ],
)
def test_bad_crop_is_refused_before_the_first_episode(
    extra, message, tmp_path, capsys, monkeypatch
):
    _no_episode(monkeypatch)
    args = ["--policy", "scripted", "--output_dir", str(tmp_path / "out"), *extra]
    rc, out, err = _eval(args, capsys)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert rc == 2 and len(lines) == 1 and message in lines[0], err
