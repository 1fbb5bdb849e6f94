"""Cost of recording one episode at the documented settings, against raw MuJoCo.

    MUJOCO_GL=egl python benchmarks/record_episode.py            # 600 steps, 4 cams, 480x640

1. Records one episode exactly as ``trossen-mujoco record`` does (phase 1 without images,
   phase 2 rendering 4 cameras and streaming to HDF5) and times it.
2. The raw floor, in the same run: a plain ``mujoco.Renderer`` loop that renders the same
   frames (same scene, same states, same cameras and size) and does nothing else.
3. Write cost and file size of each ``--compression`` option, rewriting the recorded frames.

Prints wall seconds, seconds per rendered frame, the ratio to the floor, and peak RSS.
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings  # noqa: E402
from trossen_arm_mujoco.constants import ASSETS_DIR, STATIONARY_CAMERAS  # noqa: E402
from trossen_arm_mujoco.data.reader import load_episode  # noqa: E402
from trossen_arm_mujoco.data.schema import COMPRESSIONS  # noqa: E402
from trossen_arm_mujoco.data.writer import EpisodeWriter  # noqa: E402


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def raw_floor(path: Path, cams: list[str], height: int, width: int) -> tuple[float, int]:
    """Render the recorded states with a bare mujoco.Renderer; (seconds, frames)."""
    ep = load_episode(path)
    model = mujoco.MjModel.from_xml_path(
        os.path.join(ASSETS_DIR, "stationary_ai/trossen_ai_scene_joint.xml")
    )
    data = mujoco.MjData(model)
    renderer = mujoco.Renderer(model, height, width)
    box = np.asarray(ep.env_state)
    frames = 0
    start = time.perf_counter()
    for t in range(ep.num_steps):
        data.qpos[:16] = ep.qpos[t]
        data.qpos[16:23] = box[t]
        mujoco.mj_forward(model, data)
        for cam in cams:
            renderer.update_scene(data, camera=cam)
            renderer.render()
            frames += 1
    seconds = time.perf_counter() - start
    renderer.close()
    return seconds, frames


def compression_costs(path: Path, cams: list[str], out_dir: Path) -> list[tuple[str, float, int]]:
    """(option, write seconds, bytes) for rewriting the episode with each compression."""
    ep = load_episode(path)
    results = []
    for option in COMPRESSIONS:
        target = out_dir / f"episode_{COMPRESSIONS.index(option) + 100}.hdf5"
        start = time.perf_counter()
        with (
            ep.open_frames() as frames,
            EpisodeWriter(
                target,
                ep.num_steps,
                cams,
                ep.image_shapes[cams[0]][0],
                ep.image_shapes[cams[0]][1],
                compression=option,
                attrs={k: ep.attrs[k] for k in ("task_name", "seed", "success", "box_pose")},
            ) as writer,
        ):
            for t in range(ep.num_steps):
                writer.append(
                    ep.qpos[t],
                    ep.qvel[t],
                    ep.action[t],
                    ep.reward[t],
                    ep.env_state[t],
                    frames.step(t),
                )
        results.append((option, time.perf_counter() - start, target.stat().st_size))
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episode_len", type=int, default=600)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument(
        "--no_compression", action="store_true", help="skip the compression comparison"
    )
    args = parser.parse_args()
    cams = list(STATIONARY_CAMERAS)

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        settings = RecordSettings(
            episode_len=args.episode_len,
            cam_names=tuple(cams),
            height=args.height,
            width=args.width,
        )
        start = time.perf_counter()
        recorder = EpisodeRecorder(settings)
        outcome = recorder.record(0, out / "episode_0.hdf5")
        recorder.close()
        record_s = time.perf_counter() - start
        rss_after_record = peak_rss_mb()
        frames = args.episode_len * len(cams)

        floor_s, floor_frames = raw_floor(out / "episode_0.hdf5", cams, args.height, args.width)
        size = (out / "episode_0.hdf5").stat().st_size

        print(
            f"episode: {args.episode_len} steps, {len(cams)} cameras at "
            f"{args.height}x{args.width}, success={outcome.success}"
        )
        print(
            f"record (both phases + HDF5): {record_s:8.1f} s  {record_s / frames * 1e3:7.1f} "
            f"ms/frame"
        )
        print(
            f"raw floor (mujoco.Renderer): {floor_s:8.1f} s  "
            f"{floor_s / floor_frames * 1e3:7.1f} ms/frame"
        )
        print(
            f"ratio record / floor per frame: {(record_s / frames) / (floor_s / floor_frames):.3f}"
        )
        print(f"peak RSS during recording: {rss_after_record:.0f} MB; file {size / 1e9:.2f} GB")
        print(
            "vendor package, same settings, measured on a 2-core CPU: 38 min 13 s "
            f"(this run: {record_s / 2293:.3f}x of it)"
        )
        if not args.no_compression:
            print("compression (rewrite of the recorded frames):")
            for option, seconds, nbytes in compression_costs(out / "episode_0.hdf5", cams, out):
                print(f"  {option:5s} write {seconds:6.1f} s  size {nbytes / 1e6:8.1f} MB")


if __name__ == "__main__":
    main()
