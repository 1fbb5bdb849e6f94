"""Every command checks that it can write its outputs before it starts the work: one line
naming the flag, exit 2, nothing read or recorded first (``fileio.check_writable_dir``).
Also the hints that must name the right flag (``--data_dir``, not ``--root_dir``; the CLI's
``--overwrite``, not the Python API's ``overwrite=True``) and Python warnings shown to a
command-line user as one ``note:`` line."""

from __future__ import annotations

import errno
import os
import sys
import warnings
from pathlib import Path

import pytest

from trossen_arm_mujoco import fileio
from trossen_arm_mujoco.data.io_errors import EpisodeWriteError
from trossen_arm_mujoco.data.writer import EpisodeWriter
from trossen_arm_mujoco.errors import UserError, note, plain_warnings, run_cli
from trossen_arm_mujoco.fileio import check_writable_dir, folder_problem
from trossen_arm_mujoco.scripts import export_dataset, record_sim_episodes, visualize_eps

ATTRS = {"task_name": "sim_transfer_cube", "seed": 0, "success": False}


def _episode(path: Path) -> Path:
    with EpisodeWriter(path, 2, [], 24, 32, attrs=ATTRS) as w:
        for _ in range(2):
            w.append(
                qpos=[0.0] * 16,
                qvel=[0.0] * 16,
                action=[0.0] * 16,
                reward=0.0,
                env_state=[0.0] * 7,
                images={},
            )
    return path


@pytest.fixture
def place(tmp_path) -> dict[str, Path]:
    """A folder with an episode, a plain file, a symlink loop and a dangling link."""
    eps = tmp_path / "eps"
    eps.mkdir()
    _episode(eps / "episode_0.hdf5")
    plain = tmp_path / "plain.txt"
    plain.write_text("not a folder\n")
    (tmp_path / "loop_a").symlink_to(tmp_path / "loop_b")
    (tmp_path / "loop_b").symlink_to(tmp_path / "loop_a")
    (tmp_path / "dangling").symlink_to(tmp_path / "no" / "such" / "folder")
    return {"tmp": tmp_path, "eps": eps, "file": plain}


def _tree(folder: Path) -> set[Path]:
    return set(folder.rglob("*"))


def _one_error(capfd) -> str:
    out, err = capfd.readouterr()
    assert "Traceback" not in out + err, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("error: "), lines
    return lines[0]


# -- the probe ------------------------------------------------------------------------------


def test_probe_passes_and_leaves_nothing_behind(tmp_path):
    existing = tmp_path / "out"
    existing.mkdir()
    assert check_writable_dir(existing, "--output") == existing
    assert list(existing.iterdir()) == []
    deep = tmp_path / "a" / "b" / "c"
    assert check_writable_dir(deep, "--output") == deep
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # created, then removed


def test_probe_expands_the_home_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    assert check_writable_dir("~/x", "--output") == tmp_path / "x"


@pytest.mark.parametrize(
    "name, flag, expected",
    [
        ("{file}", "--output", "it is a file; give a folder"),
        ("{file}/sub", "--output_dir", "a file is in the way ({file})"),
        ("{file}/a/b", "--data_dir", "a file is in the way ({file})"),
        ("{tmp}/loop_a", "--output", "it is a symlink loop; fix or remove the link"),
        ("{tmp}/loop_a/sub", "--output", "{tmp}/loop_a is a symlink loop"),
        ("{tmp}/dangling", "--data_dir", "it is a link to a missing path ({tmp}/no/such/folder)"),
    ],
)
def test_probe_names_the_flag_and_what_is_wrong(place, name, flag, expected):
    path = name.format(**place)
    before = _tree(place["tmp"])
    with pytest.raises(UserError) as info:
        check_writable_dir(path, flag)
    text = str(info.value)
    assert text.startswith(f"cannot write to {flag} {path}: "), text
    assert expected.format(**place) in text
    assert f"another {flag}" in text or "give a folder" in text
    assert "\n" not in text
    assert _tree(place["tmp"]) == before


def test_folder_problem_is_none_for_folders_and_missing_paths(place):
    assert folder_problem(place["eps"]) is None
    assert folder_problem(place["tmp"] / "new" / "deeper") is None
    (place["tmp"] / "link").symlink_to(place["eps"])
    assert folder_problem(place["tmp"] / "link" / "videos") is None  # a working link
    assert folder_problem(place["file"]) == (place["file"], "is a file, not a folder")


def test_probe_really_writes_and_turns_the_os_error_into_one_line(tmp_path, monkeypatch):
    real_open = os.open

    def full(path, flags, *args):
        if Path(path).name.startswith(fileio.PROBE_PREFIX):
            raise OSError(errno.ENOSPC, "No space left on device", str(path))
        return real_open(path, flags, *args)

    monkeypatch.setattr(fileio.os, "open", full)
    with pytest.raises(UserError) as info:
        check_writable_dir(tmp_path / "new" / "out", "--output")
    text = str(info.value)
    assert text.startswith(f"cannot write to --output {tmp_path / 'new' / 'out'}: ")
    assert "No space left on device (ENOSPC)" in text and "free some disk space" in text
    assert list(tmp_path.iterdir()) == []  # the folders it made are removed again


def test_probe_on_a_read_only_file_system(tmp_path, fs_faults):
    with fs_faults.tmpfs(tmp_path / "ro", read_only=True, folders=("old",)) as ro:
        for target in (ro, ro / "old", ro / "new" / "deeper"):
            with pytest.raises(UserError, match=r"Read-only file system \(EROFS\).*--output"):
                check_writable_dir(target, "--output")
        assert os.listdir(ro) == ["old"]


# -- each command checks first -------------------------------------------------------------


def _forbid(monkeypatch, module, *names: str) -> list[str]:
    """Replace ``module.<name>`` by functions that note the call and fail: work the
    command must not start before its output check."""
    called: list[str] = []
    for name in names:

        def boom(*args, _name=name, **kwargs):
            called.append(_name)
            raise AssertionError(f"{_name} called before the output check")

        monkeypatch.setattr(module, name, boom)
    return called


BAD_OUTPUTS = [
    ("{file}", "it is a file"),
    ("{file}/sub", "a file is in the way"),
    ("{tmp}/loop_a", "is a symlink loop"),
    ("{tmp}/dangling", "is a link to a missing path"),
]


@pytest.mark.parametrize("target, why", BAD_OUTPUTS)
def test_record_checks_data_dir_before_anything(place, target, why, monkeypatch, capfd):
    called = _forbid(monkeypatch, record_sim_episodes, "record_options")
    data_dir = target.format(**place)
    before = _tree(place["tmp"])
    rc = record_sim_episodes.cli(["--data_dir", data_dir, "--num_episodes", "1"])
    line = _one_error(capfd)
    assert rc == 2 and called == []
    assert line.startswith(f"error: cannot write to --data_dir {data_dir}: ") and why in line
    assert "--root_dir" not in line
    assert _tree(place["tmp"]) == before


def test_record_names_root_dir_when_the_root_is_at_fault(place, monkeypatch, capfd):
    called = _forbid(monkeypatch, record_sim_episodes, "record_options")
    root = place["file"] / "datasets"
    rc = record_sim_episodes.cli(["--root_dir", str(root), "--data_dir", "demo"])
    line = _one_error(capfd)
    assert rc == 2 and called == []
    assert line.startswith(f"error: cannot write to --root_dir {root}: a file is in the way")


@pytest.mark.parametrize("target, why", BAD_OUTPUTS)
def test_export_checks_output_before_reading_episodes(place, target, why, monkeypatch, capfd):
    from trossen_arm_mujoco.export import lerobot

    called = _forbid(monkeypatch, lerobot, "list_episodes", "load_episode", "plan_export")
    output = target.format(**place)
    before = _tree(place["tmp"])
    argv = ["--data_dir", str(place["eps"]), "--output", output, "--repo_id", "me/ds"]
    rc = export_dataset.cli(argv)
    line = _one_error(capfd)
    assert rc == 2 and called == []
    assert line.startswith(f"error: cannot write to --output {output}: ") and why in line
    assert _tree(place["tmp"]) == before


@pytest.mark.parametrize("target, why", BAD_OUTPUTS)
def test_visualize_checks_output_before_reading_episodes(place, target, why, monkeypatch, capfd):
    called = _forbid(monkeypatch, visualize_eps, "list_episodes", "load_episode")
    output = target.format(**place)
    before = _tree(place["tmp"])
    rc = visualize_eps.cli(["--data_dir", str(place["eps"]), "--output_dir", output])
    line = _one_error(capfd)
    assert rc == 2 and called == []
    assert line.startswith(f"error: cannot write to --output_dir {output}: ") and why in line
    assert _tree(place["tmp"]) == before


def test_every_command_on_a_read_only_file_system(place, fs_faults, monkeypatch, capfd):
    """A real refusal of the file system (not a path shape): the probe's write fails."""
    from trossen_arm_mujoco.export import lerobot

    called = _forbid(monkeypatch, record_sim_episodes, "record_options")
    called += _forbid(monkeypatch, lerobot, "list_episodes")
    called += _forbid(monkeypatch, visualize_eps, "list_episodes")
    eps = str(place["eps"])
    with fs_faults.tmpfs(place["tmp"] / "ro", read_only=True, folders=("empty",)) as ro:
        runs = [
            ("--data_dir", record_sim_episodes.cli, ["--data_dir", str(ro / "demo")]),
            ("--data_dir", record_sim_episodes.cli, ["--root_dir", str(ro), "--data_dir", "d"]),
            (
                "--output",
                export_dataset.cli,
                ["--data_dir", eps, "--output", str(ro / "ds"), "--repo_id", "me/ds"],
            ),
            ("--output_dir", visualize_eps.cli, ["--data_dir", eps, "--output_dir", str(ro)]),
            (
                "--output_dir",
                visualize_eps.cli,
                ["--data_dir", eps, "--output_dir", str(ro / "empty" / "videos")],
            ),
        ]
        for flag, cli, argv in runs:
            assert cli(argv) == 2, argv
            line = _one_error(capfd)
            assert line.startswith(f"error: cannot write to {flag} "), line
            assert "Read-only file system (EROFS)" in line and f"another {flag}" in line
        assert sorted(os.listdir(ro)) == ["empty"] and os.listdir(ro / "empty") == []
    assert called == []


def test_a_writable_output_passes_the_check(place, monkeypatch, capfd):
    """The check lets a good output through: the command goes on to its work (here
    stopped at once by the sentinel), and the probe leaves nothing behind."""
    called = _forbid(monkeypatch, visualize_eps, "list_episodes")
    with pytest.raises(AssertionError, match="list_episodes called"):
        visualize_eps.main(["--data_dir", str(place["eps"]), "--output_dir", "videos"])
    assert called == ["list_episodes"]
    assert sorted(p.name for p in place["eps"].iterdir()) == ["episode_0.hdf5"]


# -- hints that name the right flag --------------------------------------------------------


def test_episode_name_that_is_a_folder_is_refused_before_recording(place, monkeypatch, capfd):
    from trossen_arm_mujoco.collect import parallel

    data = place["tmp"] / "data"
    (data / "episode_1.hdf5").mkdir(parents=True)
    called = _forbid(monkeypatch, parallel, "DatasetRecorder")
    for extra in ([], ["--overwrite"]):
        argv = ["--data_dir", str(data), "--num_episodes", "2", "--cam_names", "none", *extra]
        assert record_sim_episodes.cli(argv) == 2
        line = _one_error(capfd)
        assert "episode_1.hdf5 is a folder, not an episode file" in line, line
        assert "--data_dir" in line and "overwrite=True" not in line
    assert called == []
    assert sorted(p.name for p in data.iterdir()) == ["episode_1.hdf5"]
    # A folder named like an episode the run does not reach is left alone.
    from trossen_arm_mujoco.collect.resume import check_episode_names

    check_episode_names(data, 1)
    with pytest.raises(UserError, match="episode_1.hdf5 is a folder"):
        check_episode_names(data, 2)


def test_episode_name_that_is_a_dangling_link_is_refused(tmp_path):
    from trossen_arm_mujoco.collect.resume import check_episode_names

    (tmp_path / "episode_0.hdf5").symlink_to(tmp_path / "gone.hdf5")
    with pytest.raises(UserError, match=r"episode_0.hdf5 is a link to a missing path"):
        check_episode_names(tmp_path, 1)


def test_writer_hints_in_python_and_on_the_command_line(tmp_path):
    path = _episode(tmp_path / "episode_0.hdf5")
    with pytest.raises(EpisodeWriteError) as info:
        EpisodeWriter(path, 2, [], 24, 32, attrs=ATTRS)
    exc = info.value
    assert "pass overwrite=True" in str(exc)  # the Python API's words for API callers
    assert "--overwrite" in exc.cli_message and "overwrite=True" not in exc.cli_message
    assert exc.cli_message.startswith(f"{path} already exists; refusing to overwrite it (")
    folder = tmp_path / "episode_1.hdf5"
    folder.mkdir()
    for overwrite in (False, True):  # a folder is never replaced: no overwrite hint at all
        with pytest.raises(EpisodeWriteError) as info:
            EpisodeWriter(folder, 2, [], 24, 32, attrs=ATTRS, overwrite=overwrite)
        assert "is a folder, not an episode file" in str(info.value)
        assert "overwrite" not in str(info.value).split("refusing")[1]
    assert folder.is_dir() and list(folder.iterdir()) == []


def test_run_cli_prints_the_cli_hint_and_it_survives_pickling(capsys):
    import pickle

    exc = UserError("x exists", hint="pass overwrite=True", cli_hint="pass --overwrite")
    assert str(exc) == "x exists (pass overwrite=True)"
    again = pickle.loads(pickle.dumps(exc))
    assert (str(again), again.cli_message) == (str(exc), "x exists (pass --overwrite)")

    def main(argv):
        raise again

    assert run_cli(main, []) == 2
    assert capsys.readouterr().err == "error: x exists (pass --overwrite)\n"
    assert UserError("plain").cli_message == "plain"
    assert UserError("a", hint="b").cli_message == "a (b)"


# -- warnings reach a command-line user as one plain line -----------------------------------


def test_a_warning_in_a_command_is_one_note_line(capfd):
    def main(argv):
        warnings.warn("the cube is\nred", stacklevel=1)
        warnings.warn("old flag", DeprecationWarning, stacklevel=1)
        return 0

    previous = warnings.showwarning
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert run_cli(main, []) == 0
    out, err = capfd.readouterr()
    assert err == "note: the cube is; red\nnote: old flag (DeprecationWarning)\n"
    assert warnings.showwarning is previous  # restored after the command


def test_plain_warnings_and_note(capfd):
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        with plain_warnings():
            warnings.warn("careful", RuntimeWarning, stacklevel=1)
        note("two\nlines")
    err = capfd.readouterr().err
    assert err == "note: careful (RuntimeWarning)\nnote: two; lines\n"
    assert __file__ not in err and sys.executable not in err
