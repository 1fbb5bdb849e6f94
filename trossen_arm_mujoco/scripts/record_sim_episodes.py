"""Record scripted demonstrations into HDF5 episodes (also ``trossen-mujoco record``).

    python trossen_arm_mujoco/scripts/record_sim_episodes.py --data_dir demo --num_episodes 2

Phase 1 runs the scripted policy in the end-effector env (no rendering); phase 2 replays the
joint trajectory in the joint env, rendering the requested cameras and streaming every step
to ``<root_dir>/<data_dir>/episode_<k>.hdf5`` (images gzip-compressed unless
``--compression none``). Unset flags come from ``SIM_TASK_CONFIGS[task_name]``.

One run writes to a folder at a time: a second one refuses with the first one's pid, or
waits for it with ``--wait``. A rerun continues the dataset: it checks every episode there
(unreadable files and episodes recorded with other flags stop it with one line) and records
the missing and the failed ones. The last line says how many episodes succeeded and, when
some failed, why; the exit status is 1 when some failed (they are kept, and a rerun records
them again). Ctrl-C or SIGTERM keeps every finished episode. A write the file system refuses
(disk full, read-only folder, folder removed) ends the run with one ``error:`` line listing
the complete episodes; no partial file is left.
"""

from __future__ import annotations

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import argparse
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from trossen_arm_mujoco.collect.resume import format_indices
from trossen_arm_mujoco.constants import ROOT_DIR, SIM_TASK_CONFIGS
from trossen_arm_mujoco.data.schema import COMPRESSIONS, DEFAULT_COMPRESSION, GZIP_LEVEL
from trossen_arm_mujoco.errors import (
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    ArgumentParser,
    UserError,
    redeliver_if_in_finalizer,
    report_error,
    run_cli,
    unknown_name_error,
)

if TYPE_CHECKING:
    from trossen_arm_mujoco.collect.parallel import DatasetRecorder, RunPlan

#: Longest episode accepted (steps; 2000 s at 50 Hz).
MAX_EPISODE_LEN = 100_000
#: Most episodes one dataset may be asked to hold.
MAX_EPISODES = 1_000_000
#: Largest run seed (stored as a signed 64-bit attribute).
MAX_SEED = 2**63 - 1
#: Exit status when some episodes failed (without --skip_failed).
EXIT_FAILED_EPISODES = 1


def build_parser() -> argparse.ArgumentParser:
    p = ArgumentParser(
        prog="trossen-mujoco record",
        description="Record scripted simulation episodes (two-phase: mocap rollout, joint "
        "replay with cameras) into HDF5 files.",
    )
    p.add_argument(
        "--task_name",
        default="sim_transfer_cube",
        help="task to record (default: sim_transfer_cube)",
    )
    p.add_argument(
        "--data_dir", required=True, help="dataset folder, relative to --root_dir unless absolute"
    )
    p.add_argument("--root_dir", default=ROOT_DIR, help=f"root of datasets (default: {ROOT_DIR})")
    p.add_argument(
        "--num_episodes",
        type=int,
        default=None,
        help="episodes the dataset should hold (default: task config)",
    )
    p.add_argument(
        "--episode_len",
        type=int,
        default=None,
        help=f"steps per episode at 50 Hz, at most {MAX_EPISODE_LEN} (default: task config, 600)",
    )
    p.add_argument(
        "--onscreen_render",
        action="store_true",
        default=None,
        help="show a live viewer with the camera images while recording",
    )
    p.add_argument(
        "--inject_noise",
        action="store_true",
        default=None,
        help="perturb the scripted waypoints (seeded)",
    )
    p.add_argument(
        "--randomize",
        action="store_true",
        help="domain randomization (lights, table and object colours and textures, friction, "
        "masses, damping, cameras, joint noise) as the task YAML's 'randomization' section "
        "says; each episode stores it in its 'randomization' attribute (default: off)",
    )
    p.add_argument(
        "--cam_names",
        default=None,
        help="comma-separated cameras to record, or 'none' (default: all 4)",
    )
    p.add_argument(
        "--seed",
        type=int,
        default=0,
        help="run seed, 0 .. 2**63-1; episode k uses a seed derived from (seed, k) (default: 0)",
    )
    p.add_argument(
        "--num_workers",
        type=int,
        default=None,
        help="episodes recorded at once: local worker processes (default: 1; at most the "
        "CPUs, a worker that dies is replaced and its episode retried), or with --engine ray "
        "the Ray tasks in flight (default: the cluster's CPUs; also the CPUs of a local "
        "Ray); results are identical for any number",
    )
    p.add_argument(
        "--engine",
        default="local",
        choices=("local", "ray"),
        help="where episodes run: local processes, or one Ray task each (default: local)",
    )
    p.add_argument(
        "--ray_address",
        default=None,
        help="with --engine ray: 'auto', HOST:PORT or ray://HOST:PORT of a running Ray "
        "cluster (default: start a local Ray on this machine)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="start afresh at episode 0, replacing existing episodes",
    )
    p.add_argument(
        "--skip_failed",
        action="store_true",
        help="keep attempting until num_episodes successful episodes are saved (without it "
        "failed episodes are kept, the exit status is 1, and a rerun records them again)",
    )
    p.add_argument(
        "--wait",
        action="store_true",
        help="when another record run is writing to the folder, wait for it to finish and "
        "then continue the dataset (default: refuse, naming its pid)",
    )
    p.add_argument(
        "--compression",
        default=DEFAULT_COMPRESSION,
        choices=COMPRESSIONS,
        help=f"image compression (default: {DEFAULT_COMPRESSION}, level {GZIP_LEVEL}, "
        "compressed off the render path; 'none' for raw frames)",
    )
    p.add_argument(
        "--image_size", default="480x640", help="camera image size HEIGHTxWIDTH (default: 480x640)"
    )
    p.add_argument(
        "--no_shadows",
        action="store_true",
        help="render without shadows (faster with software rendering)",
    )
    p.add_argument(
        "--visual",
        default="own",
        help="arm meshes: 'own' (default) or 'menagerie' (the official Trossen meshes of the "
        "MuJoCo Menagerie checkout named by TROSSEN_MENAGERIE_DIR)",
    )
    return p


def _image_size(text: str) -> tuple[int, int]:
    try:
        h, w = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise UserError(f"--image_size must look like 480x640, got '{text}'") from None
    if not (0 < h <= 480 and 0 < w <= 640):
        raise UserError(f"--image_size must be within 1x1 .. 480x640, got {h}x{w}")
    return h, w


def _cameras(text: str | None, task_name: str) -> tuple[str, ...]:
    defaults = SIM_TASK_CONFIGS[task_name]["cam_names"]
    if text is None:
        return tuple(defaults)
    if text.strip().lower() == "none":
        return ()
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise UserError("--cam_names is empty; give camera names or 'none'")
    for name in names:
        if name not in defaults:
            raise unknown_name_error("camera", name, defaults, "or 'none' for no images")
    if len(set(names)) != len(names):
        raise UserError(f"--cam_names lists a camera twice: {names}")
    return tuple(names)


def _looks(args: argparse.Namespace):
    """The scene looks of --no_shadows / --visual, checked now (before any episode)."""
    from trossen_arm_mujoco.sim.looks import SceneLooks, menagerie_meshes

    looks = SceneLooks(shadows=not args.no_shadows, visual=args.visual)
    if looks.visual == "menagerie":
        menagerie_meshes()  # fail now with the fix, not in a worker
    return looks


def _dataset_folder(root: str, data_dir: str) -> Path:
    from trossen_arm_mujoco.data.reader import resolve_data_dir

    folder = resolve_data_dir(root, data_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(
            f"cannot write to {folder}: {exc.strerror or exc}; choose another --root_dir"
        ) from None
    return folder


def _check_writable(folder: Path) -> None:
    """Create and remove a file of this run's own (another process never shares its name)."""
    import secrets

    probe = folder / f".write_test.{os.getpid()}-{secrets.token_hex(4)}"
    try:
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise UserError(
            f"cannot write to {folder}: {exc.strerror or exc}; choose another --root_dir"
        ) from None


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # not Linux
        return os.cpu_count() or 1


def _num_workers(args: argparse.Namespace) -> int | None:
    """``--num_workers``, at most the CPUs of this machine (with a warning) unless the
    episodes run on a Ray cluster elsewhere."""
    n = args.num_workers
    if n is None or (args.engine == "ray" and args.ray_address is not None):
        return n
    cpus = _cpus()
    if n > cpus:
        print(
            f"warning: --num_workers {n} is more than the {cpus} CPUs of this machine; "
            f"using {cpus}",
            file=sys.stderr,
        )
        return cpus
    return n


def _check_numbers(args: argparse.Namespace, num_episodes: int, episode_len: int) -> None:
    if not 1 <= num_episodes <= MAX_EPISODES:
        raise UserError(f"--num_episodes must be in 1 .. {MAX_EPISODES}, got {num_episodes}")
    if not 1 <= episode_len <= MAX_EPISODE_LEN:
        raise UserError(
            f"--episode_len must be in 1 .. {MAX_EPISODE_LEN} steps (2000 s at 50 Hz), "
            f"got {episode_len}"
        )
    if not 0 <= args.seed <= MAX_SEED:
        raise UserError(f"--seed must be in 0 .. 2**63-1 ({MAX_SEED}), got {args.seed}")
    if args.num_workers is not None and args.num_workers < 1:
        raise UserError(f"--num_workers must be at least 1, got {args.num_workers}")


def _on_wait(folder: Path):
    def say(pid, host) -> None:
        from trossen_arm_mujoco.data.dataset_lock import holder_text

        print(
            f"waiting for the record run ({holder_text(pid, host)}) writing to {folder} to "
            "finish (Ctrl-C to stop waiting)",
            file=sys.stderr,
            flush=True,
        )

    return say


def _warn_disk_space(folder: Path, settings, count: int) -> None:
    """Warn when raw (uncompressed) episodes cannot fit in the free space."""
    import shutil

    if settings.compression != "none":
        return  # compressed sizes are not known in advance
    per_step = len(settings.cam_names) * settings.height * settings.width * 3 + 4 * 56
    need = per_step * settings.episode_len * count
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    if need > free:
        from trossen_arm_mujoco.collect.parallel import format_size

        print(
            f"warning: {count} episode(s) need about {format_size(need)} but {folder} has "
            f"{format_size(free)} free; free disk space, record fewer episodes or use "
            "--compression gzip",
            file=sys.stderr,
        )


def _raise_hangup(signum, frame):  # a closed terminal: the same clean path as Ctrl-C
    if redeliver_if_in_finalizer(signum, frame):
        return
    raise KeyboardInterrupt


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from trossen_arm_mujoco.tasks.registry import ALIASES

    args.task_name = ALIASES.get(args.task_name, args.task_name)  # old names keep working
    if args.task_name not in SIM_TASK_CONFIGS:
        raise unknown_name_error("task", args.task_name, SIM_TASK_CONFIGS)
    config = SIM_TASK_CONFIGS[args.task_name]
    num_episodes = config["num_episodes"] if args.num_episodes is None else args.num_episodes
    episode_len = config["episode_len"] if args.episode_len is None else args.episode_len
    onscreen = config["onscreen_render"] if args.onscreen_render is None else True
    noise = config["inject_noise"] if args.inject_noise is None else True
    _check_numbers(args, num_episodes, episode_len)
    if args.ray_address is not None and args.engine != "ray":
        raise UserError("--ray_address needs --engine ray")
    if onscreen and (args.engine != "local" or (args.num_workers or 1) != 1):
        raise UserError("--onscreen_render needs --engine local and --num_workers 1")
    if args.engine == "ray":
        from trossen_arm_mujoco.collect.ray_session import import_ray

        import_ray()  # fail now, with the install hint, when Ray is missing
    cams = _cameras(args.cam_names, args.task_name)
    height, width = _image_size(args.image_size)
    looks = _looks(args)
    args.num_workers = _num_workers(args)

    from trossen_arm_mujoco.collect.pipeline import RecordSettings

    settings = RecordSettings(
        task_name=args.task_name,
        episode_len=episode_len,
        inject_noise=noise,
        cam_names=cams,
        height=height,
        width=width,
        compression=args.compression,
        base_seed=args.seed,
        randomize=args.randomize,
        shadows=looks.shadows,
        visual=looks.visual,
    )
    folder = _dataset_folder(args.root_dir, args.data_dir)
    from trossen_arm_mujoco.data.dataset_lock import DatasetLock

    hangup = _catch_hangup()
    try:
        with DatasetLock(folder, wait=args.wait, on_wait=_on_wait(folder)):
            return _record(args, settings, folder, num_episodes, onscreen)
    finally:
        if hangup is not None:
            signal.signal(signal.SIGHUP, hangup)


def _catch_hangup():
    """SIGHUP (the terminal closed) ends the run like Ctrl-C; returns the previous handler."""
    import threading

    sighup = getattr(signal, "SIGHUP", None)
    if sighup is None or threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.getsignal(sighup)
    if previous == signal.SIG_IGN:  # nohup: keep running
        return None
    signal.signal(sighup, _raise_hangup)
    return signal.SIG_DFL if previous is None else previous


def _record(args, settings, folder: Path, num_episodes: int, onscreen: bool) -> int:
    """The run, inside the folder's lock."""
    from trossen_arm_mujoco.collect.parallel import failure_summary, format_size, plan_run
    from trossen_arm_mujoco.collect.pipeline import policy_minimum_episode_len

    _check_writable(folder)
    plan = plan_run(folder, num_episodes, args.overwrite, settings)
    if not plan.indices:
        print(
            f"{folder} already holds {format_indices(plan.existing)}; nothing to record "
            "(raise --num_episodes to add more, or --overwrite to start afresh)"
        )
        return 0
    _say_plan(plan, folder, num_episodes)
    episode_len = settings.episode_len
    minimum_len = policy_minimum_episode_len(args.task_name)
    if episode_len < minimum_len:
        print(
            f"warning: --episode_len {episode_len} is shorter than the {minimum_len} steps "
            f"the scripted policy of '{args.task_name}' needs; its episodes will end before "
            f"the task is done and count as failed (use --episode_len {minimum_len} or more)",
            file=sys.stderr,
        )
    _warn_disk_space(folder, settings, len(plan.indices))
    print(
        f"recording {format_indices(plan.indices)} of '{args.task_name}' "
        f"({episode_len} steps, cameras: {', '.join(settings.cam_names) or 'none'}"
        f"{', randomized' if args.randomize else ''}) into {folder}"
    )

    viewer = None
    hook = None
    if onscreen:
        viewer, hook = _live_view_hook(settings)
    start = time.perf_counter()
    try:
        with _engine(args, hook) as make_recorder:
            recorder = make_recorder(
                settings, folder, skip_failed=args.skip_failed, overwrite=args.overwrite
            )
            report = recorder.run(num_episodes, plan)
    finally:
        if viewer is not None and viewer[0] is not None:
            viewer[0].close()
    wall = time.perf_counter() - start
    saved = report.saved
    if report.io_error is not None:
        return report_error(f"{report.io_error}; {_kept(folder)}; {_io_hint(report.io_error)}")
    if report.interrupted:
        kept = sorted(k for k, _ in _episodes(folder))
        print(
            f"interrupted ({'SIGTERM' if report.terminated else 'Ctrl-C'}): the episodes in "
            f"progress were discarded; {len(kept)} finished episode(s) kept in {folder} "
            f"({format_indices(kept)}){_missing(kept, num_episodes)}; rerun the same command "
            "to continue",
            file=sys.stderr,
        )
        return EXIT_TERMINATED if report.terminated else EXIT_INTERRUPTED
    episodes = _episodes(folder)
    total_bytes = sum(path.stat().st_size for _, path in episodes)
    print(
        f"recorded {len(saved)} episode(s) in {wall:.1f} s, {format_size(report.saved_bytes)}; "
        f"dataset: {len(episodes)} episode(s), {format_size(total_bytes)} in {folder}"
    )
    noun, total = ("attempts", report.attempts) if args.skip_failed else ("episodes", len(saved))
    why = failure_summary(report.failed, total, noun, episode_len, minimum_len)
    if args.skip_failed:
        print(f"attempts: {report.attempts} (bound {recorder.max_attempts(len(plan.indices))})")
        if len(saved) < len(plan.indices):
            print(f"Success: {report.successes} / {report.attempts}")
            raise UserError(
                f"only {len(saved)} successful episodes after {report.attempts} "
                f"attempts ({why}); check the task or rerun to continue"
            )
        why = why and f"{why} (discarded)"
    print(f"Success: {report.successes} / {total}" + (f"; {why}" if why else ""))
    failed = report.failed_indices
    if failed and not args.skip_failed:
        print(
            f"failed: {format_indices(failed)} kept with success=False; rerunning the same "
            "command records them again (or pass --skip_failed to keep only successes)",
            file=sys.stderr,
        )
        return EXIT_FAILED_EPISODES
    return 0


def _say_plan(plan: RunPlan, folder: Path, num_episodes: int) -> None:
    """One line on what a run that continues a dataset keeps and records."""
    if not (plan.existing or plan.failed):
        return
    parts = [f"keeping {format_indices(plan.existing)}"] if plan.existing else []
    gaps = [k for k in plan.gaps if k < num_episodes and k in plan.indices]
    if gaps:
        parts.append(f"missing: {format_indices(gaps)}")
    again = [k for k in plan.indices if k in plan.failed]
    if again:
        parts.append(f"failed before, recording again: {format_indices(again)}")
    print(f"continuing the dataset in {folder}: " + "; ".join(parts))


def _missing(kept: list[int], num_episodes: int) -> str:
    missing = sorted(set(range(num_episodes)) - set(kept))
    return f"; missing: {format_indices(missing)}" if missing and kept else ""


@contextmanager
def _engine(
    args: argparse.Namespace, step_hook: Callable | None
) -> Iterator[Callable[..., DatasetRecorder]]:
    """A recorder factory for ``--engine``; with Ray, connected for the block's duration."""
    from trossen_arm_mujoco.collect.parallel import DatasetRecorder

    if args.engine == "local":
        yield partial(DatasetRecorder, num_workers=args.num_workers or 1, step_hook=step_hook)
        return
    from trossen_arm_mujoco.collect.ray_engine import RayDatasetRecorder
    from trossen_arm_mujoco.collect.ray_session import ray_session

    with ray_session(args.ray_address, num_cpus=args.num_workers):
        yield partial(RayDatasetRecorder, max_in_flight=args.num_workers)


def _episodes(folder: Path):
    from trossen_arm_mujoco.data.reader import list_episodes

    return list_episodes(folder, missing_ok=True)


def _kept(folder: Path) -> str:
    """``"complete episodes: 0..1 in <folder>"`` (what survives an I/O error)."""
    if not folder.is_dir():
        return "complete episodes: none (the folder is gone)"
    kept = sorted(k for k, _ in _episodes(folder))
    if not kept:
        return "complete episodes: none"
    return f"complete episodes: {format_indices(kept)} in {folder}"


def _io_hint(exc) -> str:
    import errno

    if exc.folder_missing:
        return "rerun to record again"
    if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return "free disk space or choose another --root_dir, then rerun to continue"
    if exc.errno in (errno.EAGAIN, errno.ENOENT):
        return (
            "another program changed or holds files in the folder; stop it (or use another "
            "--data_dir), then rerun to continue"
        )
    return "check the folder's permissions or choose another --root_dir, then rerun to continue"


def _live_view_hook(settings):
    """A step hook that shows the joint env and its camera images in a live viewer."""
    from trossen_arm_mujoco.viewer import LiveViewer

    holder: list = [None]

    def hook(t: int, observation: dict, env) -> None:
        if holder[0] is None:
            holder[0] = LiveViewer.open(env.model, env.data)
        if holder[0] is not None:
            holder[0].update(observation.get("images"))

    return holder, hook


def cli(argv: Sequence[str] | None = None) -> int:
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
