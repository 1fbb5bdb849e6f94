"""Recording on Ray: same files as the local engine, resume, skip_failed, interrupts, and a
worker that dies. One local Ray (2 CPUs, loopback only) serves the whole module."""

from __future__ import annotations

import os
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

pytest.importorskip("ray")

from trossen_arm_mujoco.collect.parallel import STAGING, DatasetRecorder  # noqa: E402
from trossen_arm_mujoco.collect.pipeline import RecordSettings  # noqa: E402
from trossen_arm_mujoco.collect.ray_engine import RayDatasetRecorder  # noqa: E402
from trossen_arm_mujoco.collect.ray_session import is_loopback_node, ray_session  # noqa: E402
from trossen_arm_mujoco.collect.resume import plan_run  # noqa: E402
from trossen_arm_mujoco.data.reader import list_episodes  # noqa: E402
from trossen_arm_mujoco.errors import UserError  # noqa: E402
from trossen_arm_mujoco.scripts.record_sim_episodes import cli  # noqa: E402

STATE = RecordSettings(episode_len=20)
#: The shortest episodes the scripted transfer succeeds in (failed ones are recorded again).
SUCCEEDS = RecordSettings(episode_len=440)
CAMERA = RecordSettings(episode_len=20, cam_names=("cam_high",), height=16, width=16)


@pytest.fixture(scope="module")
def ray_instance():
    with ray_session(None, num_cpus=2) as ray:
        yield ray


def _quiet(_line: str) -> None:
    pass


def _local(folder, n, settings=STATE, **kwargs):
    rec = DatasetRecorder(settings, folder, log=_quiet, **kwargs)
    return rec.run(n, plan_run(folder, n, kwargs.get("overwrite", False)))


def _on_ray(folder, n, settings=STATE, log=_quiet, **kwargs):
    rec = RayDatasetRecorder(settings, folder, log=log, **kwargs)
    return rec.run(n, plan_run(folder, n, kwargs.get("overwrite", False)))


def _h5_items(path: Path) -> dict:
    """Every dataset (values, dtype, chunking, filters) and every attribute of a file."""
    items = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            for key, value in obj.attrs.items():
                items[f"{name}@{key}"] = np.asarray(value)
            if isinstance(obj, h5py.Dataset):
                items[name] = obj[()]
                items[f"{name}#layout"] = (obj.dtype.str, obj.chunks, obj.compression)

        for key, value in f.attrs.items():
            items[f"/@{key}"] = np.asarray(value)
        f.visititems(visit)
    return items


def _assert_same_file(a: Path, b: Path) -> None:
    ia, ib = _h5_items(a), _h5_items(b)
    assert ia.keys() == ib.keys()
    for key in ia:
        if key.endswith("#layout"):
            assert ia[key] == ib[key], key
        else:
            np.testing.assert_array_equal(ia[key], ib[key], err_msg=key)
    assert a.read_bytes() == b.read_bytes()  # no attribute differs (no host, no time)


def _names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def test_local_ray_is_loopback_only(ray_instance):
    assert is_loopback_node(ray_instance)
    pids = _descendants(os.getpid())
    sockets = _sockets_of(pids)
    assert sockets, "the Ray processes hold no TCP socket: the check would see nothing"
    for local, remote in sockets:
        assert _loopback_or_any(local), local
        assert _loopback_or_any(remote), remote
    # the Ray processes find ray_bootstrap_config.yaml in HOME, so the head does not probe
    # the cloud-metadata address to label usage statistics
    # (only Ray's processes: the test session may have other children, e.g. a resource tracker)
    ray_pids = {pid for pid in pids if b"ray" in _cmdline(pid)}
    homes = {_environ(pid).get("HOME") for pid in ray_pids} - {None}
    assert homes and all(Path(h, "ray_bootstrap_config.yaml").is_file() for h in homes)


def test_ray_and_local_give_identical_files(ray_instance, tmp_path):
    for settings, n in ((STATE, 3), (CAMERA, 2)):
        local, ray = tmp_path / f"local{n}", tmp_path / f"ray{n}"
        _local(local, n, settings)
        report = _on_ray(ray, n, settings)
        assert [o.attempt for o in report.saved] == list(range(n))
        assert _names(ray) == _names(local) == [f"episode_{k}.hdf5" for k in range(n)]
        for k in range(n):
            _assert_same_file(local / f"episode_{k}.hdf5", ray / f"episode_{k}.hdf5")


def test_resume_continues_after_highest_index(ray_instance, tmp_path):
    _on_ray(tmp_path / "r", 1, SUCCEEDS)
    before = (tmp_path / "r" / "episode_0.hdf5").stat().st_mtime_ns
    report = _on_ray(tmp_path / "r", 3, SUCCEEDS)
    assert [o.attempt for o in report.saved] == [1, 2]
    assert (tmp_path / "r" / "episode_0.hdf5").stat().st_mtime_ns == before
    _local(tmp_path / "l", 3, SUCCEEDS)
    for k in range(3):
        _assert_same_file(
            tmp_path / "l" / f"episode_{k}.hdf5", tmp_path / "r" / f"episode_{k}.hdf5"
        )


def test_skip_failed_is_bounded_and_leaves_nothing(ray_instance, tmp_path):
    # 20 steps are far too short to transfer the cube: every attempt fails
    rec = RayDatasetRecorder(STATE, tmp_path, skip_failed=True, log=_quiet)
    report = rec.run(1, plan_run(tmp_path, 1, False))
    assert report.attempts == rec.max_attempts(1) == 13
    assert report.saved == [] and list(tmp_path.iterdir()) == []


def test_skip_failed_saves_the_same_success_as_local(ray_instance, tmp_path):
    settings = RecordSettings(episode_len=440)  # the shortest the scripted transfer needs
    _local(tmp_path / "l", 1, settings, skip_failed=True)
    report = _on_ray(tmp_path / "r", 1, settings, skip_failed=True)
    assert [(o.attempt, o.success) for o in report.saved] == [(0, True)]
    assert _names(tmp_path / "r") == ["episode_0.hdf5"]
    _assert_same_file(tmp_path / "l" / "episode_0.hdf5", tmp_path / "r" / "episode_0.hdf5")


def _crash_first_try(marker_dir: Path, attempt: int):
    """A worker hook that kills the worker process the first time it runs ``attempt``."""

    def before(k: int) -> None:
        marker = marker_dir / f"crashed_{k}"
        if k == attempt and not marker.exists():
            marker.write_text(str(os.getpid()))
            os._exit(1)

    return before


def test_dead_worker_loses_only_its_episode_which_is_retried(ray_instance, tmp_path):
    markers = tmp_path / "markers"
    markers.mkdir()
    report = _on_ray(tmp_path / "r", 3, before_attempt=_crash_first_try(markers, 1))
    assert (markers / "crashed_1").is_file()  # the worker running attempt 1 did die
    assert [o.attempt for o in report.saved] == [0, 1, 2]
    _local(tmp_path / "l", 3)
    assert _names(tmp_path / "r") == _names(tmp_path / "l")
    for k in range(3):
        _assert_same_file(
            tmp_path / "l" / f"episode_{k}.hdf5", tmp_path / "r" / f"episode_{k}.hdf5"
        )


def test_max_in_flight_bounds_the_attempts_running_at_once(ray_instance, tmp_path):
    starts = tmp_path / "starts"
    starts.mkdir()

    def stamp(k: int) -> None:
        (starts / str(k)).write_text(repr(time.time()))
        time.sleep(0.3)

    _on_ray(tmp_path / "r", 3, max_in_flight=1, before_attempt=stamp)
    times = [float((starts / str(k)).read_text()) for k in range(3)]
    assert all(b - a >= 0.3 for a, b in zip(times, times[1:])), times  # one after the other


def test_worker_dying_every_time_is_one_line_error(ray_instance, tmp_path):
    def always_die(k: int) -> None:
        os._exit(1)

    with pytest.raises(
        UserError, match="attempt 0: the Ray worker running it was lost in each of 1 tries"
    ):
        _on_ray(tmp_path, 1, max_retries=0, before_attempt=always_die)
    assert list(tmp_path.iterdir()) == []


def test_user_error_in_a_task_is_raised_as_it_is(ray_instance, tmp_path):
    def refuse(k: int) -> None:
        raise UserError(f"attempt {k} refused")

    with pytest.raises(UserError, match="^attempt 0 refused$"):
        _on_ray(tmp_path, 1, before_attempt=refuse)


def test_interrupt_publishes_finished_attempts_and_resume_fills_the_gap(ray_instance, tmp_path):
    """Ctrl-C while attempt 1 runs and attempt 2 has finished: episodes 0 and 2 are kept
    (nothing finished is lost), nothing else is left, and a rerun records episode 1 with
    attempt 1, completing the dataset of an uninterrupted run."""
    folder, markers = tmp_path / "r", tmp_path / "markers"
    markers.mkdir()

    def slow_first_run(k: int) -> None:
        deadline = time.time() + 120
        while k == 1 and not (markers / "resume").exists() and time.time() < deadline:
            time.sleep(0.05)

    def interrupt_once_2_is_done(line: str) -> None:
        if line.startswith("episode 0:"):
            deadline = time.time() + 120
            while not (folder / STAGING / "attempt_2.hdf5").exists():
                assert time.time() < deadline, "attempt 2 never finished"
                time.sleep(0.05)
            raise KeyboardInterrupt

    report = _on_ray(
        folder, 3, SUCCEEDS, log=interrupt_once_2_is_done, before_attempt=slow_first_run
    )
    assert report.interrupted and [o.attempt for o in report.saved] == [0, 2]
    assert report.saved_at == [0, 2]
    assert _names(folder) == ["episode_0.hdf5", "episode_2.hdf5"]
    (markers / "resume").write_text("")
    report = _on_ray(folder, 3, SUCCEEDS, before_attempt=slow_first_run)
    assert [o.attempt for o in report.saved] == [1] and report.saved_at == [1]
    _local(tmp_path / "l", 3, SUCCEEDS)
    for k in range(3):
        _assert_same_file(tmp_path / "l" / f"episode_{k}.hdf5", folder / f"episode_{k}.hdf5")


def test_record_cli_engine_ray(ray_instance, tmp_path, capsys):
    args = ["--data_dir", "d", "--root_dir", str(tmp_path), "--episode_len", "20"]
    rc = cli([*args, "--cam_names", "none", "--num_episodes", "2", "--engine", "ray"])
    out = capsys.readouterr().out
    assert rc == 1, out  # the episodes failed (kept): exit status 1
    # 20 steps are too short for the scripted transfer: both fail, and the line says why
    assert out.strip().splitlines()[-1].startswith("Success: 0 / 2; 2 of 2 episodes failed")
    assert [k for k, _ in list_episodes(tmp_path / "d")] == [0, 1]
    assert ray_instance.is_initialized()  # the CLI used the running instance and left it


# --- sockets of this process's descendants (Linux /proc) -------------------------------------


def _descendants(root: int) -> set[int]:
    parents = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            parents[int(entry.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    found, frontier = set(), {root}
    while frontier:
        frontier = {pid for pid, ppid in parents.items() if ppid in frontier} - found
        found |= frontier
    return found


def _cmdline(pid: int) -> bytes:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return b""


def _environ(pid: int) -> dict[str, str]:
    try:
        raw = Path(f"/proc/{pid}/environ").read_bytes()
    except OSError:
        return {}
    pairs = (item.split(b"=", 1) for item in raw.split(b"\0") if b"=" in item)
    return {k.decode(errors="replace"): v.decode(errors="replace") for k, v in pairs}


def _sockets_of(pids: set[int]) -> list[tuple[str, str]]:
    """(local, remote) hex addresses of the TCP/UDP sockets the processes hold."""
    inodes = set()
    for pid in pids:
        try:
            links = [os.readlink(p) for p in Path(f"/proc/{pid}/fd").iterdir()]
        except OSError:
            continue
        inodes |= {link[8:-1] for link in links if link.startswith("socket:[")}
    found = []
    for table in ("tcp", "tcp6", "udp", "udp6"):
        lines = Path(f"/proc/net/{table}").read_text().splitlines()[1:]
        for line in lines:
            fields = line.split()
            if fields[9] in inodes:
                found.append((fields[1].split(":")[0], fields[2].split(":")[0]))
    return found


def _loopback_or_any(hex_address: str) -> bool:
    """127.0.0.0/8, ::1, ::ffff:127.x, or the unspecified address (a listener's wildcard,
    or no peer)."""
    raw = bytes.fromhex(hex_address)
    words = [raw[i : i + 4][::-1] for i in range(0, len(raw), 4)]  # host-order words
    ip = b"".join(words)
    if len(ip) == 4:
        return ip[0] == 127 or ip == bytes(4)
    return ip in (bytes(16), bytes(15) + b"\1") or (
        ip[:12] == bytes(10) + b"\xff\xff" and ip[12] == 127
    )
