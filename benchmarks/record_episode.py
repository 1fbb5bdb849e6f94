"""Cost of recording one episode at the documented settings, against raw MuJoCo.

    MUJOCO_GL=egl python benchmarks/record_episode.py            # 600 steps, 4 cams, 480x640
    MUJOCO_GL=egl python benchmarks/record_episode.py --episode_len 150 --repeats 3   # quicker

1. Records one episode exactly as ``trossen-mujoco record`` does (phase 1 without images,
   phase 2 rendering 4 cameras and streaming to HDF5, default compression) and times it.
2. Marginal cost per rendered step, in the same run: phase 2 (render the cameras, step,
   write the step) with ``--compression none`` and with the default (gzip, compressed in
   background threads), against the raw floor: a plain ``mujoco.Renderer`` + ``mj_step``
   loop on the same scene (same model, initial state, controls, cameras and size) that does
   nothing else. The three are interleaved ``--repeats`` times; the fastest of each counts
   (the machine may be shared), and the ratio to the floor is printed per variant.
3. Size and write cost of every compression option and gzip level, rewriting the recorded
   frames: time spent in ``EpisodeWriter.append`` + ``close`` (reading the frames back is
   not counted) and the zlib CPU time per frame.

Prints wall seconds, seconds per rendered step, the ratios, and peak RSS.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import tempfile
import time
import zlib
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from trossen_arm_mujoco.collect.pipeline import (  # noqa: E402
    EpisodeRecorder,
    RecordSettings,
    episode_seed,
)
from trossen_arm_mujoco.constants import STATIONARY_CAMERAS  # noqa: E402
from trossen_arm_mujoco.data.reader import load_episode  # noqa: E402
from trossen_arm_mujoco.data.schema import DEFAULT_COMPRESSION, GZIP_LEVEL  # noqa: E402
from trossen_arm_mujoco.data.writer import EpisodeWriter  # noqa: E402

#: Compression options of the size table: (label, compression, gzip level).
OPTIONS = [("none", "none", None), ("lzf", "lzf", None)] + [
    (f"gzip {level}", "gzip", level) for level in (1, 4, 6, 9)
]


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _writer(recorder: EpisodeRecorder, path: Path, compression: str, poses) -> EpisodeWriter:
    s = recorder.settings
    return EpisodeWriter(
        path,
        s.episode_len,
        s.cam_names,
        s.height,
        s.width,
        compression=compression,
        attrs={"task_name": recorder.entry.name, "seed": 0, "success": False},
        env_state_dim=7 * len(poses),
    )


def phase2(recorder: EpisodeRecorder, actions, poses, path: Path, compression: str) -> float:
    """Seconds of phase 2 (render, step, write every step, commit) with ``compression``."""
    start = time.perf_counter()
    with _writer(recorder, path, compression, poses) as writer:
        recorder.replay(actions, poses, writer)
    seconds = time.perf_counter() - start
    path.unlink()
    return seconds


class RawFloor:
    """A bare ``mujoco.Renderer`` + ``mj_step`` loop on the joint env's model: same initial
    state, the controls phase 2 applied, the same cameras and size; nothing else."""

    def __init__(self, recorder: EpisodeRecorder, actions, poses) -> None:
        env = recorder.joint_env
        ctrls: list[np.ndarray] = []
        recorder.joint_sampler.sample_task(0, object_poses=poses)
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.state = np.empty(mujoco.mj_stateSize(env.model, spec))
        mujoco.mj_getState(env.model, env.data, self.state, spec)
        hook, recorder.step_hook = (
            recorder.step_hook,
            lambda t, obs, e: ctrls.append(e.data.ctrl.copy()),
        )
        try:
            recorder.replay(actions, poses)  # no images: just the controls of every step
        finally:
            recorder.step_hook = hook
        self.ctrls = ctrls
        self.model, self.substeps = env.model, env.n_substeps
        s = recorder.settings
        self.cams, self.size = list(s.cam_names), (s.height, s.width)

    def run(self) -> float:
        model, spec = self.model, mujoco.mjtState.mjSTATE_FULLPHYSICS
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, self.state, spec)
        mujoco.mj_forward(model, data)
        renderer = mujoco.Renderer(model, *self.size)
        start = time.perf_counter()
        for ctrl in self.ctrls:
            for cam in self.cams:
                renderer.update_scene(data, camera=cam)
                renderer.render()
            data.ctrl[:] = ctrl
            mujoco.mj_step(model, data, nstep=self.substeps)
        seconds = time.perf_counter() - start
        renderer.close()
        return seconds


def compression_table(path: Path, out_dir: Path) -> list[tuple[str, float, float, int]]:
    """(option, write seconds, zlib CPU ms per frame, bytes) per compression option."""
    ep = load_episode(path)
    cams = ep.camera_names
    h, w = ep.image_shapes[cams[0]][:2]
    rows = []
    for label, compression, level in OPTIONS:
        target = out_dir / "episode_900.hdf5"
        kwargs = {"gzip_level": level} if level else {}
        writing = 0.0
        zlib_cpu = 0.0
        writer = EpisodeWriter(
            target,
            ep.num_steps,
            cams,
            h,
            w,
            compression=compression,
            attrs={k: ep.attrs[k] for k in ("task_name", "seed", "success")},
            env_state_dim=ep.env_state.shape[1],
            **kwargs,
        )
        with ep.open_frames() as frames:
            for t in range(ep.num_steps):
                images = frames.step(t)
                if level and t % 10 == 0:  # zlib alone, single thread, every 10th step
                    c0 = time.process_time()
                    for frame in images.values():
                        zlib.compress(frame, level)
                    zlib_cpu += time.process_time() - c0
                start = time.perf_counter()
                writer.append(
                    ep.qpos[t], ep.qvel[t], ep.action[t], ep.reward[t], ep.env_state[t], images
                )
                writing += time.perf_counter() - start
        start = time.perf_counter()
        writer.close()
        writing += time.perf_counter() - start
        sampled = len(range(0, ep.num_steps, 10)) * len(cams)
        rows.append((label, writing, zlib_cpu / sampled * 1e3, target.stat().st_size))
        target.unlink()
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episode_len", type=int, default=600)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--repeats", type=int, default=2, help="interleaved runs of section 2")
    parser.add_argument("--no_compression", action="store_true", help="skip the compression table")
    args = parser.parse_args()
    cams = list(STATIONARY_CAMERAS)
    settings = RecordSettings(
        episode_len=args.episode_len, cam_names=tuple(cams), height=args.height, width=args.width
    )
    steps, frames = args.episode_len, args.episode_len * len(cams)

    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        start = time.perf_counter()
        recorder = EpisodeRecorder(settings)
        outcome = recorder.record(0, out / "episode_0.hdf5")
        record_s = time.perf_counter() - start
        rss_after_record = peak_rss_mb()
        size = (out / "episode_0.hdf5").stat().st_size
        print(
            f"episode: {steps} steps, {len(cams)} cameras at {args.height}x{args.width}, "
            f"success={outcome.success}, {os.cpu_count()} CPUs, load average "
            f"{os.getloadavg()[0]:.1f}"
        )
        print(
            f"record (both phases + HDF5, {DEFAULT_COMPRESSION} {GZIP_LEVEL}): {record_s:8.1f} s "
            f"{record_s / frames * 1e3:7.1f} ms/frame; file {size / 1e6:.1f} MB; peak RSS "
            f"{rss_after_record:.0f} MB"
        )

        actions, poses = recorder.scripted_rollout(np.random.default_rng(episode_seed(0, 0)))
        floor = RawFloor(recorder, actions, poses)
        runs: dict[str, list[float]] = {"floor": [], "none": [], DEFAULT_COMPRESSION: []}
        variants = list(runs)
        for rep in range(args.repeats):
            for name in variants[rep % 3 :] + variants[: rep % 3]:  # rotate the order
                if name == "floor":
                    runs[name].append(floor.run())
                else:
                    runs[name].append(phase2(recorder, actions, poses, out / "p2.hdf5", name))
        recorder.close()
        best = {name: min(times) / steps for name, times in runs.items()}
        print(f"per rendered step ({len(cams)} frames), best of {args.repeats} interleaved runs:")
        for name, seconds in best.items():
            label = "raw floor (Renderer + mj_step)" if name == "floor" else f"phase 2, {name}"
            median = statistics.median(runs[name]) / steps
            print(
                f"  {label:32s} {seconds * 1e3:7.1f} ms (median {median * 1e3:7.1f})  "
                f"ratio to floor {seconds / best['floor']:.3f} "
                f"(median {median / (statistics.median(runs['floor']) / steps):.3f})"
            )
        print(
            "vendor package, same settings, measured on a 2-core CPU: 38 min 13 s "
            f"(this run: {record_s / 2293:.3f}x of it)"
        )
        if not args.no_compression:
            print(f"compression (rewrite of the recorded frames, {steps} steps):")
            print("  option   write (s)  zlib CPU/frame (ms)  size (MB)  size/raw")
            rows = compression_table(out / "episode_0.hdf5", out)
            raw = next(r[3] for r in rows if r[0] == "none")
            for label, seconds, cpu_ms, nbytes in rows:
                cpu = f"{cpu_ms:8.2f}" if cpu_ms else "       -"
                print(
                    f"  {label:7s} {seconds:9.1f}  {cpu:>19s}  {nbytes / 1e6:9.1f}  "
                    f"{nbytes / raw:7.3f}"
                )


if __name__ == "__main__":
    main()
