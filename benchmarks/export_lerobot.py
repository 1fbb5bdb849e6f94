"""Speed and fidelity of the LeRobot export, against bare PyAV encoding of the same frames.

    MUJOCO_GL=egl python benchmarks/export_lerobot.py                 # records 2 x 150 steps
    MUJOCO_GL=egl python benchmarks/export_lerobot.py --data_dir DIR  # existing episodes
    ... --lerobot_python /path/to/py312/bin/python                    # also LeRobot's writer

1. Exports the episodes with each encoding (AV1 yuv420p = the default, H.264 yuv420p,
   H.264 yuv444p) and times it: frames/s (a frame = one step, all cameras).
2. The floor, in the same run: the same frames, already in memory, encoded by PyAV with the
   same settings into one mp4 per camera, nothing else. Ratio = export time / floor.
3. Fidelity: PSNR (dB) of every decoded frame against the HDF5 frame (min and mean), and
   bytes per frame.
4. With ``--lerobot_python`` (a Python >= 3.12 with ``lerobot[dataset]``): LeRobot's own
   writer (``LeRobotDataset.create`` + ``add_frame`` + ``save_episode``) on the same frames.
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from fractions import Fraction
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("SVT_LOG", "1")

import av  # noqa: E402
import numpy as np  # noqa: E402

from trossen_arm_mujoco.data.reader import list_episodes, load_episode  # noqa: E402
from trossen_arm_mujoco.export import VideoSettings, export_lerobot  # noqa: E402
from trossen_arm_mujoco.export.lerobot_video import ENCODERS  # noqa: E402
from trossen_arm_mujoco.images import psnr  # noqa: E402
from trossen_arm_mujoco.robot.lerobot_keys import image_key  # noqa: E402

ENCODINGS = {
    "av1 yuv420p (default)": VideoSettings(),
    "h264 yuv420p": VideoSettings(codec="h264"),
    "h264 yuv444p crf 12": VideoSettings(codec="h264", pix_fmt="yuv444p", crf=12),
}


def record(folder: Path, steps: int, cams: str, size: str) -> None:
    from trossen_arm_mujoco.scripts.record_sim_episodes import cli

    args = ["--data_dir", str(folder), "--num_episodes", "2", "--episode_len", str(steps)]
    rc = cli([*args, "--cam_names", cams, "--image_size", size])
    if rc not in (0, 1):  # 1: some episodes failed (kept all the same)
        sys.exit(rc)


def floor_seconds(frames: dict[str, np.ndarray], video: VideoSettings, fps: int) -> float:
    """Bare PyAV encode of in-memory frames, one in-memory mp4 per camera."""
    start = time.perf_counter()
    for images in frames.values():
        with av.open(io.BytesIO(), "w", format="mp4") as out:
            stream = out.add_stream(
                ENCODERS[video.codec], rate=Fraction(fps), options=video.options()
            )
            stream.height, stream.width = images.shape[1:3]
            stream.pix_fmt = video.pix_fmt
            for i, image in enumerate(images):
                frame = av.VideoFrame.from_ndarray(image, format="rgb24")
                frame.pts = i
                out.mux(stream.encode(frame))
            out.mux(stream.encode(None))
    return time.perf_counter() - start


def fidelity(root: Path, frames: dict[str, np.ndarray]) -> tuple[float, float, float]:
    """(min PSNR, mean PSNR, bytes per frame) over every camera's decoded frames."""
    psnrs, size, count = [], 0, 0
    for cam, source in frames.items():
        files = sorted((root / "videos" / image_key(cam)).rglob("*.mp4"))
        decoded = []
        for path in files:
            size += path.stat().st_size
            with av.open(str(path)) as container:
                decoded += [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
        psnrs += [min(psnr(a, b), 100.0) for a, b in zip(decoded, source, strict=True)]
        count += len(source)
    return min(psnrs), float(np.mean(psnrs)), size / count


LEROBOT_SCRIPT = textwrap.dedent(
    """
    import glob, os, sys, time
    os.environ["HF_HUB_OFFLINE"] = "1"
    import numpy as np
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    src, root = sys.argv[1], sys.argv[2]
    eps = [dict(np.load(p)) for p in sorted(glob.glob(src + "/ep*.npz"))]
    cams = [k[4:] for k in eps[0] if k.startswith("img_")]
    vec = {"dtype": "float32", "shape": (16,), "names": None}
    features = {"observation.state": vec, "observation.velocity": vec, "action": vec}
    for c in cams:
        shape = eps[0]["img_" + c].shape[1:]
        features["observation.images." + c] = {"dtype": "video", "shape": shape,
                                               "names": ["height", "width", "channels"]}
    start = time.perf_counter()
    ds = LeRobotDataset.create("bench/lerobot", fps=50, features=features, root=root)
    n = 0
    for ep in eps:
        for t in range(len(ep["qpos"])):
            frame = {"observation.state": ep["qpos"][t], "observation.velocity": ep["qvel"][t],
                     "action": ep["action"][t], "task": "bench"}
            for c in cams:
                frame["observation.images." + c] = ep["img_" + c][t]
            ds.add_frame(frame)
            n += 1
        ds.save_episode()
    ds.finalize()
    print("LEROBOT", n, time.perf_counter() - start)
    """
)


def lerobot_writer(python: str, data_dir: Path, tmp: Path) -> tuple[int, float]:
    npz = tmp / "npz"
    npz.mkdir()
    for k, path in list_episodes(data_dir):
        ep = load_episode(path, load_images=True)
        arrays = {f"img_{c}": ep.images[c] for c in ep.camera_names}
        np.savez(
            npz / f"ep{k}.npz",
            qpos=ep.qpos.astype(np.float32),
            qvel=ep.qvel.astype(np.float32),
            action=ep.action.astype(np.float32),
            **arrays,
        )
    out = subprocess.run(
        [python, "-c", LEROBOT_SCRIPT, str(npz), str(tmp / "lerobot_ds")],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    _, n, seconds = next(line for line in out.splitlines() if line.startswith("LEROBOT")).split()
    return int(n), float(seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data_dir", default=None, help="episodes to export (default: record)")
    parser.add_argument("--steps", type=int, default=150, help="steps per recorded episode")
    parser.add_argument("--cams", default="cam_high,cam_left_wrist", help="recorded cameras")
    parser.add_argument("--image_size", default="480x640", help="recorded image size")
    parser.add_argument("--lerobot_python", default=None, help="Python with lerobot[dataset]")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        data_dir = Path(args.data_dir) if args.data_dir else tmp / "eps"
        if args.data_dir is None:
            record(data_dir, args.steps, args.cams, args.image_size)
        episodes = [load_episode(p, load_images=True) for _, p in list_episodes(data_dir)]
        cams = episodes[0].camera_names
        frames = {c: np.concatenate([ep.images[c] for ep in episodes]) for c in cams}
        steps = sum(ep.num_steps for ep in episodes)
        h, w = episodes[0].image_shapes[cams[0]][:2]
        print(f"{len(episodes)} episodes, {steps} steps, {len(cams)} cameras {h}x{w}")
        print(
            f"{'encoding':24s} {'export f/s':>10s} {'floor f/s':>9s} {'ratio':>6s} "
            f"{'PSNR min':>8s} {'mean':>5s} {'KiB/frame':>9s}"
        )
        for name, video in ENCODINGS.items():
            out = tmp / name.replace(" ", "_")
            summary = export_lerobot(  # every recorded frame, as the LeRobot writer below
                data_dir,
                out,
                "bench/ds",
                video=video,
                progress=False,
                fps=round(1 / episodes[0].dt),
                sim_features=True,
            )
            floor = floor_seconds(frames, video, summary.fps)
            low, mean, per_frame = fidelity(out, frames)
            print(
                f"{name:24s} {steps / summary.seconds:10.1f} {steps / floor:9.1f} "
                f"{summary.seconds / floor:6.2f} {low:8.1f} {mean:5.1f} {per_frame / 1024:9.1f}"
            )
        if args.lerobot_python:
            n, seconds = lerobot_writer(args.lerobot_python, data_dir, tmp)
            print(f"LeRobot's writer (AV1 yuv420p): {n / seconds:.1f} frames/s ({seconds:.1f} s)")


if __name__ == "__main__":
    main()
