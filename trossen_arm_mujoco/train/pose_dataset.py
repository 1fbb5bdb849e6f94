"""A LeRobot dataset whose ``observation.environment_state`` is what a pose encoder sees in
the camera, not the simulation's exact poses: what a policy that deploys is trained on.

:func:`derive_dataset` trains a :mod:`.pose_encoder` once on an exported dataset's episode
files (their rendered frames) and writes a copy of the dataset whose object poses (xyz m +
quat wxyz per object, world) are the encoder's estimates, with their statistics, the camera
videos left out unless ``keep_images``; the encoder and its report lie beside it
(``pose_files``). Command line (``[train]`` extra: torch)::

    python -m trossen_arm_mujoco.train.pose_dataset DATASET EPISODES OUTPUT [--camera cam_high]
        [--keep_images]

Docs: docs/train-eval.md, docs/cli/prepare.md; details: docs/concepts/design-notes.md.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path
from typing import Any

import numpy as np

from trossen_arm_mujoco.data.reader import list_episodes, load_episode
from trossen_arm_mujoco.errors import UserError, run_cli
from trossen_arm_mujoco.export.lerobot_plan import frame_map
from trossen_arm_mujoco.export.lerobot_stats import array_stats, to_lists
from trossen_arm_mujoco.robot.lerobot_keys import ENV_STATE_KEY, image_camera
from trossen_arm_mujoco.train.pose_encoder import EPOCHS, save_encoder, train_encoder
from trossen_arm_mujoco.train.pose_files import ENCODER_FILE, REPORT_FILE

__all__ = ["derive_dataset", "main"]


def _info(dataset: Path) -> dict[str, Any]:
    try:
        return json.loads((dataset / "meta" / "info.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise UserError(
            f"{dataset}: not a LeRobot dataset ({exc}); give the folder trossen-mujoco export wrote"
        ) from None


def _camera(info: dict[str, Any], camera: str | None, dataset: Path) -> str:
    cams = [c for c in map(image_camera, info["features"]) if c is not None]
    if camera is None and len(cams) == 1:
        return cams[0]
    if camera not in cams:
        raise UserError(
            f"--camera {camera}: {dataset} has cameras {cams or 'none'}; "
            "choose one (export with --cam_names to add one)"
        )
    return camera


def _read_rows(dataset: Path) -> tuple[list[Path], np.ndarray, np.ndarray, np.ndarray]:
    import pyarrow.parquet as pq

    files = sorted((dataset / "data").glob("chunk-*/file-*.parquet"))
    if not files:
        raise UserError(f"{dataset}: no data files under data/; export it again")
    eps, frames, env = [], [], []
    for f in files:
        t = pq.read_table(f, columns=["episode_index", "frame_index", ENV_STATE_KEY])
        eps.append(t["episode_index"].to_numpy())
        frames.append(t["frame_index"].to_numpy())
        env.append(np.stack(t[ENV_STATE_KEY].to_numpy(zero_copy_only=False)))
    return files, np.concatenate(eps), np.concatenate(frames), np.concatenate(env)


def _frames(
    episodes: Path, camera: str, fps: int, episode: np.ndarray, env: np.ndarray
) -> np.ndarray:
    """Each dataset row's camera frame, from the episode files (dataset episode i is the
    i-th file, as export numbers them; checked against the first pose of each)."""
    files = list_episodes(episodes)
    n_eps = int(episode.max()) + 1
    if len(files) < n_eps:
        raise UserError(
            f"{episodes} holds {len(files)} episode files, the dataset "
            f"{n_eps}: give the folder it was exported from"
        )
    out = []
    for i in range(n_eps):
        rows = np.nonzero(episode == i)[0]
        ep = load_episode(files[i][1], load_images=True)
        if ep.images is None or camera not in ep.images:
            raise UserError(
                f"{files[i][1]} has no {camera} frames: record with --cam_names {camera}"
            )
        fm = frame_map(ep.num_steps, int(round(1.0 / ep.dt)), fps)
        if (
            fm.length != len(rows)
            or ep.env_state is None
            or not np.allclose(ep.env_state[0], env[rows[0]], atol=1e-4)
        ):
            raise UserError(
                f"{files[i][1]} is not the dataset's episode {i}: give the "
                "episodes folder the dataset was exported from"
            )
        out.append(ep.images[camera][fm.image_index])
    return np.concatenate(out)


def _static_frames(
    folder: Path, camera: str, shape: tuple[int, ...]
) -> tuple[np.ndarray, np.ndarray]:
    """The first frame of ``camera`` and the object poses of each episode in ``folder`` (the
    scene at its start), checked against the dataset's image ``shape``."""
    files = list_episodes(folder)
    if not files:
        raise UserError(
            f"{folder}: no episode files; record them with trossen-mujoco record "
            "--episode_len 3 and the dataset's camera settings"
        )
    images, poses = [], []
    for _, path in files:
        ep = load_episode(path, load_images=True)
        if ep.images is None or camera not in ep.images or ep.env_state is None:
            raise UserError(
                f"{path} has no {camera} frames or no object poses: record with "
                f"--cam_names {camera}"
            )
        frame = ep.images[camera][0]
        if frame.shape != shape:
            raise UserError(
                f"{path}: {camera} frames are {frame.shape}, the dataset's "
                f"{shape}: record with its --image_size and --crop"
            )
        images.append(frame)
        poses.append(ep.env_state[0])
    return np.stack(images), np.asarray(poses, np.float32)


def _write_rows(files: list[Path], out: Path, dataset: Path, pred: np.ndarray) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    start = 0
    for f in files:
        target = out / f.relative_to(dataset)
        t = pq.read_table(f)
        n = t.num_rows
        col = t.schema.field(ENV_STATE_KEY)
        values = pa.array(
            [row for row in pred[start : start + n].astype(np.float32)], type=col.type
        )
        t = t.set_column(t.schema.get_field_index(ENV_STATE_KEY), col, values)
        pq.write_table(t, target)
        start += n


def _write_stats(out: Path, episode: np.ndarray, pred: np.ndarray) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    stats_path = out / "meta" / "stats.json"
    stats = json.loads(stats_path.read_text(encoding="utf-8"))
    stats[ENV_STATE_KEY] = to_lists(array_stats(pred))
    stats_path.write_text(json.dumps(stats, indent=4), encoding="utf-8")
    for f in sorted((out / "meta" / "episodes").glob("chunk-*/file-*.parquet")):
        t = pq.read_table(f)
        per_ep = {
            int(i): to_lists(array_stats(pred[episode == i])) for i in t["episode_index"].to_numpy()
        }
        for name in per_ep[next(iter(per_ep))]:
            key = f"stats/{ENV_STATE_KEY}/{name}"
            if key not in t.column_names:
                continue
            col = t.schema.field(key)
            values = pa.array(
                [per_ep[int(i)][name] for i in t["episode_index"].to_numpy()], type=col.type
            )
            t = t.set_column(t.schema.get_field_index(key), col, values)
        pq.write_table(t, f)


def _drop_images(out: Path) -> list[str]:
    """Remove the image features from the dataset folder ``out`` (videos, ``info.json``
    features, ``stats.json`` entries, the per-episode video and stats columns); returns the
    keys removed."""
    import pyarrow.parquet as pq

    info_path = out / "meta" / "info.json"
    info = json.loads(info_path.read_text(encoding="utf-8"))
    keys = [k for k in info["features"] if image_camera(k) is not None]
    for k in keys:
        del info["features"][k]
        shutil.rmtree(out / "videos" / k, ignore_errors=True)
    if (out / "videos").is_dir() and not any((out / "videos").iterdir()):
        (out / "videos").rmdir()
    info_path.write_text(json.dumps(info, indent=4), encoding="utf-8")
    stats_path = out / "meta" / "stats.json"
    stats = json.loads(stats_path.read_text(encoding="utf-8"))
    stats_path.write_text(
        json.dumps({k: v for k, v in stats.items() if k not in keys}, indent=4), encoding="utf-8"
    )
    prefixes = tuple(f"{part}/{k}/" for k in keys for part in ("videos", "stats"))
    for f in sorted((out / "meta" / "episodes").glob("chunk-*/file-*.parquet")):
        t = pq.read_table(f)
        pq.write_table(t.drop_columns([c for c in t.column_names if c.startswith(prefixes)]), f)
    return keys


def derive_dataset(
    dataset: str | Path,
    episodes: str | Path,
    output: str | Path,
    *,
    camera: str | None = None,
    seed: int = 0,
    epochs: int = EPOCHS,
    threads: int | None = None,
    overwrite: bool = False,
    keep_images: bool = False,
    static_episodes: str | Path | None = None,
    augment: bool = False,
    progress: Any = print,
) -> dict[str, Any]:
    """Train the encoder on ``episodes``' frames of ``camera`` (the dataset's only camera
    when None) and write the derived dataset to ``output``, without its camera videos unless
    ``keep_images``; returns the encoder's report (errors in mm on held-out episodes, CPU and
    wall seconds). ``static_episodes``: a folder of short episodes of the same task and camera
    settings whose first frames (the arms at home, the objects sampled) the encoder also
    trains on (``pose_encoder.train_encoder``'s ``static``); ``augment``: train on frames with
    the light, colour and place changed (``pose_encoder.augment_batch``).

    Args:
        dataset: the exported LeRobot dataset folder.
        episodes: the folder of the episode files it was exported from.
        output: the derived dataset's folder.
        camera: the camera the encoder reads (None: the dataset's only one).
        seed: the encoder's initial weights and frame order.
        epochs: training epochs.
        threads: torch threads (None: torch's default).
        overwrite: replace an existing ``output``.
        keep_images: keep the camera videos in the copy.
        static_episodes: a folder of short episodes whose first frames the encoder also trains on.
        augment: train on frames with the light, colour and place changed.
        progress: gets progress lines.
    """
    from trossen_arm_mujoco.export.lerobot_output import build_folder, check_output, publish

    dataset, episodes = Path(dataset).expanduser(), Path(episodes).expanduser()
    info = _info(dataset)
    if ENV_STATE_KEY not in info.get("features", {}):
        raise UserError(
            f"{dataset} has no {ENV_STATE_KEY}: export it with --sim_features from episodes "
            "of a task with objects"
        )
    cam = _camera(info, camera, dataset)
    out = check_output(output, overwrite)
    files, episode, frame_index, env = _read_rows(dataset)
    progress(f"pose encoder: reading {cam} frames of {int(episode.max()) + 1} episodes")
    images = _frames(episodes, cam, int(info["fps"]), episode, env)
    static = None
    if static_episodes is not None:
        static = _static_frames(Path(static_episodes).expanduser(), cam, images.shape[1:])
        if static[1].shape[1] != env.shape[1]:
            raise UserError(
                f"{static_episodes}: {static[1].shape[1]} object pose values, the "
                f"dataset {env.shape[1]}: record the dataset's task"
            )
        progress(f"pose encoder: {len(static[0])} static frames from {static_episodes}")
    net, report = train_encoder(
        images,
        env,
        episode,
        frame_index,
        seed=seed,
        epochs=epochs,
        threads=threads,
        static=static,
        augment=augment,
        progress=progress,
    )
    from trossen_arm_mujoco.train.pose_encoder import predict

    pred = predict(net, images)
    with build_folder(out) as tmp:
        skip = None if keep_images else (lambda d, names: ["videos"] if Path(d) == dataset else [])
        shutil.copytree(dataset, tmp, dirs_exist_ok=True, symlinks=True, ignore=skip)
        _write_rows(files, tmp, dataset, pred)
        _write_stats(tmp, episode, pred)
        if not keep_images:
            _drop_images(tmp)
        save_encoder(net, tmp / ENCODER_FILE)
        result = {"camera": cam, "image_size": list(images.shape[1:3]), **report.as_dict()}
        (tmp / REPORT_FILE).write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
        publish(tmp, out)
    return result


def main(argv: list[str] | None = None) -> int:
    """``python -m trossen_arm_mujoco.train.pose_dataset DATASET EPISODES OUTPUT``."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("dataset", help="the exported LeRobot dataset")
    p.add_argument("episodes", help="the episode files it was exported from")
    p.add_argument("output", help="folder for the derived dataset")
    p.add_argument("--camera", default=None, help="the camera (default: the dataset's only one)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--epochs", type=int, default=EPOCHS)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--overwrite", action="store_true")
    p.add_argument(
        "--static_episodes",
        default=None,
        help="a folder of short episodes (record --episode_len 3) whose first "
        "frames, the scene at its start, the encoder also trains on",
    )
    p.add_argument(
        "--augment",
        action="store_true",
        help="train the encoder on frames with the light, the camera's exposure and "
        "white balance changed and the image shifted by up to 2 pixels",
    )
    p.add_argument(
        "--keep_images",
        action="store_true",
        help="keep the camera videos in the copy (a policy trained on the "
        "estimates does not need them)",
    )
    args = p.parse_args(argv)
    report = derive_dataset(
        args.dataset,
        args.episodes,
        args.output,
        camera=args.camera,
        seed=args.seed,
        epochs=args.epochs,
        threads=args.threads,
        overwrite=args.overwrite,
        keep_images=args.keep_images,
        static_episodes=args.static_episodes,
        augment=args.augment,
    )
    print(
        f"pose encoder on held-out episodes: start x/y error {report['start_xy_mm']:.1f} mm "
        f"(max {report['start_xy_max_mm']:.1f}), xyz over all frames "
        f"{report['mean_xyz_mm']:.1f} mm; {report['cpu_s']:.0f} s CPU; wrote {args.output}"
    )
    for k, obj in enumerate(report["objects"][1:], start=2):
        print(
            f"  object {k}: start x/y error {obj['start_xy_mm']:.1f} mm (max "
            f"{obj['start_xy_max_mm']:.1f}), xyz over all frames {obj['mean_xyz_mm']:.1f} mm"
        )
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
