"""Record scripted demonstrations into HDF5 episodes (also ``trossen-mujoco record``).

    python trossen_arm_mujoco/scripts/record_sim_episodes.py --data_dir demo --num_episodes 2

Phase 1 runs the scripted policy in the end-effector env (no rendering); phase 2 replays the
joint trajectory in the joint env, rendering the requested cameras and streaming every step
to ``<root_dir>/<data_dir>/episode_<k>.hdf5`` (images gzip-compressed unless
``--compression none``). Unset flags come from ``SIM_TASK_CONFIGS[task_name]``.

The last line says how many episodes succeeded and, when some failed, why. A write the file
system refuses (disk full, read-only folder, folder removed) ends the run with one
``error:`` line listing the complete episodes; no partial file is left.
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
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from trossen_arm_mujoco.constants import ROOT_DIR, SIM_TASK_CONFIGS
from trossen_arm_mujoco.data.schema import COMPRESSIONS, DEFAULT_COMPRESSION, GZIP_LEVEL
from trossen_arm_mujoco.errors import (
    EXIT_INTERRUPTED,
    UserError,
    report_error,
    run_cli,
    unknown_name_error,
)

if TYPE_CHECKING:
    from trossen_arm_mujoco.collect.parallel import DatasetRecorder


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
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
        help="steps per episode at 50 Hz (default: task config, 600)",
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
        help="run seed; episode k uses a seed derived from (seed, k) (default: 0)",
    )
    p.add_argument(
        "--num_workers",
        type=int,
        default=None,
        help="episodes recorded at once: local worker processes (default: 1), or with "
        "--engine ray the Ray tasks in flight (default: the cluster's CPUs; also the CPUs "
        "of a local Ray); results are identical for any number",
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
        help="keep attempting until num_episodes successful episodes are saved",
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


def _writable_folder(root: str, data_dir: str) -> Path:
    from trossen_arm_mujoco.data.reader import resolve_data_dir

    folder = resolve_data_dir(root, data_dir)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / ".write_test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise UserError(
            f"cannot write to {folder}: {exc.strerror or exc}; choose another --root_dir"
        ) from None
    return folder


def _raise_interrupt(signum, frame):  # SIGTERM -> same clean path as Ctrl-C
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
    if num_episodes < 1:
        raise UserError(f"--num_episodes must be at least 1, got {num_episodes}")
    if episode_len < 1:
        raise UserError(f"--episode_len must be at least 1, got {episode_len}")
    if args.num_workers is not None and args.num_workers < 1:
        raise UserError(f"--num_workers must be at least 1, got {args.num_workers}")
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
    folder = _writable_folder(args.root_dir, args.data_dir)

    from trossen_arm_mujoco.collect.parallel import failure_summary, format_size, plan_run
    from trossen_arm_mujoco.collect.pipeline import RecordSettings, policy_minimum_episode_len

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
    plan = plan_run(folder, num_episodes, args.overwrite)
    if plan.first_index >= num_episodes:
        print(
            f"{folder} already holds episodes 0..{plan.first_index - 1}; nothing to record "
            f"(raise --num_episodes to add more, or --overwrite to start afresh)"
        )
        return 0
    if plan.first_index:
        print(f"continuing after existing episode {plan.first_index - 1} in {folder}")
    minimum_len = policy_minimum_episode_len(args.task_name)
    if episode_len < minimum_len:
        print(
            f"warning: --episode_len {episode_len} is shorter than the {minimum_len} steps "
            f"the scripted policy of '{args.task_name}' needs; its episodes will end before "
            f"the task is done and count as failed (use --episode_len {minimum_len} or more)",
            file=sys.stderr,
        )
    print(
        f"recording episodes {plan.first_index}..{num_episodes - 1} of '{args.task_name}' "
        f"({episode_len} steps, cameras: {', '.join(cams) or 'none'}"
        f"{', randomized' if args.randomize else ''}) into {folder}"
    )

    viewer = None
    hook = None
    if onscreen:
        viewer, hook = _live_view_hook(settings)
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    start = time.perf_counter()
    try:
        with _engine(args, hook) as make_recorder:
            recorder = make_recorder(
                settings, folder, skip_failed=args.skip_failed, overwrite=args.overwrite
            )
            report = recorder.run(num_episodes, plan)
    finally:
        signal.signal(signal.SIGTERM, previous)
        if viewer is not None and viewer[0] is not None:
            viewer[0].close()
    wall = time.perf_counter() - start
    saved = report.saved
    if report.io_error is not None:
        return report_error(f"{report.io_error}; {_kept(folder)}; {_io_hint(report.io_error)}")
    if report.interrupted:
        kept = sorted(k for k, _ in _episodes(folder))
        print(
            f"interrupted: the episode in progress was discarded; {len(kept)} finished "
            f"episode(s) kept in {folder} ({_ranges(kept)}); rerun the same command to "
            "continue",
            file=sys.stderr,
        )
        return EXIT_INTERRUPTED
    episodes = _episodes(folder)
    total_bytes = sum(path.stat().st_size for _, path in episodes)
    print(
        f"recorded {len(saved)} episode(s) in {wall:.1f} s, {format_size(report.saved_bytes)}; "
        f"dataset: {len(episodes)} episode(s), {format_size(total_bytes)} in {folder}"
    )
    noun, total = ("attempts", report.attempts) if args.skip_failed else ("episodes", len(saved))
    why = failure_summary(report.failed, total, noun, episode_len, minimum_len)
    if args.skip_failed:
        print(f"attempts: {report.attempts} (bound {recorder.max_attempts(num_episodes)})")
        if len(saved) < num_episodes - plan.first_index:
            print(f"Success: {report.successes} / {report.attempts}")
            raise UserError(
                f"only {len(saved)} successful episodes after {report.attempts} "
                f"attempts ({why}); check the task or rerun to continue"
            )
        why = why and f"{why} (discarded)"
    print(f"Success: {report.successes} / {total}" + (f"; {why}" if why else ""))
    return 0


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
    return f"complete episodes: {_ranges(kept)} in {folder}" if kept else "complete episodes: none"


def _io_hint(exc) -> str:
    import errno

    if exc.folder_missing:
        return "rerun to record again"
    if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return "free disk space or choose another --root_dir, then rerun to continue"
    return "check the folder's permissions or choose another --root_dir, then rerun to continue"


def _ranges(indices: list[int]) -> str:
    if not indices:
        return "none"
    return f"episodes {indices[0]}..{indices[-1]}" if len(indices) > 1 else f"episode {indices[0]}"


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
