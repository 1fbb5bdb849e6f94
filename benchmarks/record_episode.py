"""Cost of recording one episode at the documented settings, against raw MuJoCo.

    MUJOCO_GL=egl python benchmarks/record_episode.py            # 600 steps, 4 cams, 480x640
    MUJOCO_GL=egl python benchmarks/record_episode.py --episode_len 150 --repeats 3   # quicker
    MUJOCO_GL=egl python benchmarks/record_episode.py --sweep 100,200,400,600 \
        --cam_names cam_high --height 120 --width 160 --no_shadows --json curve.json

With ``--sweep L1,L2,...`` only the sweep runs (5. below).

1. Records one episode exactly as ``trossen-mujoco record`` does (phase 1 without images,
   phase 2 rendering 4 cameras and streaming to HDF5, default compression) and times it.
2. Marginal cost per rendered step, in the same run: phase 2 (render the cameras, step,
   write the step) with ``--compression none`` and with the default (gzip, compressed in
   background threads), against the raw floor: a plain ``mujoco.Renderer`` + ``mj_step``
   loop on the same scene (same model, initial state, controls, cameras and size) that does
   nothing else. The three run side by side, interleaved in blocks of ``--block`` steps
   (rotating which goes first), so a shared machine's changing load hits all three alike;
   wall and CPU time (all threads of the process) per step and their ratios to the floor
   are printed.
3. Marginal cost per rendered step (``--marginal L1,L2``, best of ``--repeats`` runs each):
   the wall and CPU time of phase 2 (default compression, writer closed) and of the raw
   floor over the first L1 and the first L2 steps, each run on its own, not interleaved; the
   difference divided by L2 - L1 is the cost of one more step, free of the fixed costs
   (opening the GL context, the file, the last chunks' compression). Background work on a
   shared machine inflates single runs; the best of several is the least disturbed one.
4. Size and write cost of every compression option and gzip level, rewriting the recorded
   frames: time spent in ``EpisodeWriter.append`` + ``close`` (reading the frames back is
   not counted) and the deflate CPU time per frame (ISA-L's at level 1 where ``isal`` is
   installed, zlib's otherwise: what the writer uses).

5. Recording cost against episode length (``--sweep``): one episode recorded as ``record``
   records it (both phases, the file written and closed) at each length, best of
   ``--repeats``; wall and CPU seconds (all threads) of ``EpisodeRecorder.record`` alone, the
   recorder's construction (models, GL context), a fixed cost, printed apart. ``--json``
   writes the points, the settings, the date, CPU count and load average, for the docs' plot
   (``docs/data/benchmark_curves.json``, ``tools/docs_plots.py``).

Prints wall seconds, seconds per rendered step, the ratios, and peak RSS.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import platform
import resource
import tempfile
import time
from collections.abc import Iterator
from itertools import islice
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
from trossen_arm_mujoco.data.chunk_compressor import deflate_function  # noqa: E402
from trossen_arm_mujoco.data.reader import load_episode  # noqa: E402
from trossen_arm_mujoco.data.schema import DEFAULT_COMPRESSION, GZIP_LEVEL  # noqa: E402
from trossen_arm_mujoco.data.writer import EpisodeWriter  # noqa: E402
from trossen_arm_mujoco.sim.cameras import shadow_map_size  # noqa: E402

#: Compression options of the size table: (label, compression, gzip level).
OPTIONS = [("none", "none", None), ("lzf", "lzf", None)] + [
    (f"gzip {level}", "gzip", level) for level in (1, 4, 6, 9)
]


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _writer(
    recorder: EpisodeRecorder, path: Path, compression: str, poses, steps: int | None = None
) -> EpisodeWriter:
    s = recorder.settings
    return EpisodeWriter(
        path,
        s.episode_len if steps is None else steps,
        s.cam_names,
        s.height,
        s.width,
        compression=compression,
        attrs={"task_name": recorder.entry.name, "seed": 0, "success": False},
        env_state_dim=7 * len(poses),
    )


class RawFloor:
    """A bare ``mujoco.Renderer`` + ``mj_step`` loop on the joint scene's model: same initial
    state, the controls phase 2 applied, the same cameras and size; nothing else."""

    def __init__(self, recorder: EpisodeRecorder, actions, poses) -> None:
        scene = recorder.joint_scene
        ctrls: list[np.ndarray] = []
        recorder.joint_sampler.sample_task(0, object_poses=poses)
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.state = np.empty(mujoco.mj_stateSize(scene.model, spec))
        mujoco.mj_getState(scene.model, scene.data, self.state, spec)
        hook, recorder.step_hook = (
            recorder.step_hook,
            lambda t, obs, e: ctrls.append(e.data.ctrl.copy()),
        )
        try:
            recorder.replay(actions, poses)  # no images: just the controls of every step
        finally:
            recorder.step_hook = hook
        self.ctrls = ctrls
        self.model, self.substeps = scene.model, scene.n_substeps
        s = recorder.settings
        self.cams, self.size = list(s.cam_names), (s.height, s.width)

    def steps(self) -> Iterator[int]:
        """Render every camera, then step, once per recorded step; yields the step."""
        model, spec = self.model, mujoco.mjtState.mjSTATE_FULLPHYSICS
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, self.state, spec)
        mujoco.mj_forward(model, data)
        quality = model.vis.quality
        full = int(quality.shadowsize)  # the recorder's cameras size the shadow map so too
        quality.shadowsize = shadow_map_size(full, *self.size)
        try:
            renderer = mujoco.Renderer(model, *self.size)
        finally:
            quality.shadowsize = full
        with renderer:
            for t, ctrl in enumerate(self.ctrls):
                for cam in self.cams:
                    renderer.update_scene(data, camera=cam)
                    renderer.render()
                data.ctrl[:] = ctrl
                mujoco.mj_step(model, data, nstep=self.substeps)
                yield t


def side_by_side(settings, actions, poses, out: Path, block: int) -> dict[str, tuple[float, float]]:
    """{variant: (wall s, CPU s)} of the floor and phase 2 with ``none`` and the default
    compression over the whole episode, interleaved in blocks of ``block`` steps."""
    steps = len(actions)
    recorders = {name: EpisodeRecorder(settings) for name in ("none", DEFAULT_COMPRESSION)}
    floor = RawFloor(recorders["none"], actions, poses)
    writers = {
        name: _writer(rec, out / f"bench_{name}.hdf5", name, poses)
        for name, rec in recorders.items()
    }
    runs: dict[str, Iterator[int]] = {"floor": floor.steps()}
    for name, rec in recorders.items():
        runs[name] = rec.replay_steps(actions, poses, np.empty(steps), writers[name])
    totals = {name: [0.0, 0.0] for name in runs}
    order = list(runs)
    for b, first in enumerate(range(0, steps, block)):
        for name in order[b % 3 :] + order[: b % 3]:
            wall, cpu = time.perf_counter(), time.process_time()
            for _ in islice(runs[name], min(block, steps - first)):
                pass
            if first + block >= steps and name in writers:
                writers[name].close()  # the commit (pending chunks, fsync) counts too
            totals[name][0] += time.perf_counter() - wall
            totals[name][1] += time.process_time() - cpu
    for run in runs.values():
        run.close()
    for name, rec in recorders.items():
        (out / f"bench_{name}.hdf5").unlink()
        rec.close()
    return {name: (wall, cpu) for name, (wall, cpu) in totals.items()}


def _timed(run: Iterator[int], steps: int, writer: EpisodeWriter | None) -> tuple[float, float]:
    """(wall s, CPU s) of ``steps`` iterations of ``run`` (and closing ``writer``)."""
    wall, cpu = time.perf_counter(), time.process_time()
    for _ in islice(run, steps):
        pass
    if writer is not None:
        writer.close()
    took = time.perf_counter() - wall, time.process_time() - cpu
    run.close()
    return took


def marginal(settings, actions, poses, out: Path, lengths: tuple[int, int], repeats: int):
    """{variant: (wall s, CPU s) of one more step} between the two lengths, best of
    ``repeats`` runs per length (floor and phase 2 alternate, so load hits both alike)."""
    recorder = EpisodeRecorder(settings)
    floor = RawFloor(recorder, actions, poses)
    best = {
        (name, n): [float("inf"), float("inf")] for name in ("floor", "phase 2") for n in lengths
    }
    for _ in range(repeats):
        for n in lengths:
            path = out / "marginal.hdf5"
            writer = _writer(recorder, path, DEFAULT_COMPRESSION, poses, n)
            runs = {
                "floor": (floor.steps(), None),
                "phase 2": (
                    recorder.replay_steps(actions, poses, np.empty(len(actions)), writer),
                    writer,
                ),
            }
            for name, (run, w) in runs.items():
                wall, cpu = _timed(run, n, w)
                slot = best[(name, n)]
                slot[0], slot[1] = min(slot[0], wall), min(slot[1], cpu)
            path.unlink()
    recorder.close()
    a, b = lengths
    return {
        name: tuple((best[(name, b)][i] - best[(name, a)][i]) / (b - a) for i in range(2))
        for name in ("floor", "phase 2")
    }


def compression_table(path: Path, out_dir: Path) -> list[tuple[str, float, float, int]]:
    """(option, write seconds, zlib CPU ms per frame, bytes) per compression option."""
    ep = load_episode(path)
    cams = ep.camera_names
    h, w = ep.image_shapes[cams[0]][:2]
    rows = []
    for label, compression, level in OPTIONS:
        target = out_dir / "episode_900.hdf5"
        kwargs = {"gzip_level": level} if level else {}
        deflate = deflate_function(level) if level else None  # what the writer uses
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
                    c0 = time.thread_time()  # this thread only, not the writer's
                    for frame in images.values():
                        deflate(frame, level)
                    zlib_cpu += time.thread_time() - c0
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


def sweep(settings: RecordSettings, lengths: list[int], repeats: int, out: Path) -> list[dict]:
    """One point per episode length: the best (least disturbed) wall and CPU seconds of
    ``repeats`` recordings of attempt 0 at that length, and the file size (bytes)."""
    points = []
    for steps in lengths:
        start = time.perf_counter()
        recorder = EpisodeRecorder(dataclasses.replace(settings, episode_len=steps))
        setup = time.perf_counter() - start
        best_wall = best_cpu = float("inf")
        for _ in range(repeats):
            path = out / f"sweep_{steps}.hdf5"
            wall, cpu = time.perf_counter(), time.process_time()
            recorder.record(0, path, overwrite=True)
            best_wall = min(best_wall, time.perf_counter() - wall)
            best_cpu = min(best_cpu, time.process_time() - cpu)
            size = path.stat().st_size
            path.unlink()
        recorder.close()
        point = {
            "steps": steps,
            "wall_s": round(best_wall, 3),
            "cpu_s": round(best_cpu, 3),
            "setup_s": round(setup, 3),
            "bytes": size,
        }
        print(
            f"  {steps:6d} steps: wall {best_wall:7.2f} s  CPU {best_cpu:7.2f} s  "
            f"({best_wall / steps * 1e3:6.1f} ms/step; recorder setup {setup:.2f} s)  "
            f"file {size / 1e6:.2f} MB  load average {os.getloadavg()[0]:.1f}"
        )
        points.append(point)
    return points


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episode_len", type=int, default=600)
    parser.add_argument("--height", type=int, default=480)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument(
        "--block", type=int, default=20, help="steps per turn in the side-by-side timing"
    )
    parser.add_argument("--no_compression", action="store_true", help="skip the compression table")
    parser.add_argument(
        "--marginal",
        default="",
        metavar="L1,L2",
        help="also time one more rendered step between L1 and L2 steps (e.g. 40,120)",
    )
    parser.add_argument(
        "--repeats", type=int, default=3, help="runs per length (--marginal, --sweep)"
    )
    parser.add_argument(
        "--cam_names", default="all", help="comma-separated cameras, 'all' or 'none'"
    )
    parser.add_argument("--no_shadows", action="store_true", help="render without shadows")
    parser.add_argument(
        "--sweep", default="", metavar="L1,L2,...", help="only time recording at these lengths"
    )
    parser.add_argument("--json", default="", help="with --sweep: write the points here")
    args = parser.parse_args()
    names = {"all": STATIONARY_CAMERAS, "none": []}
    cams = list(names.get(args.cam_names, args.cam_names.split(",")))
    settings = RecordSettings(
        episode_len=args.episode_len,
        cam_names=tuple(cams),
        height=args.height,
        width=args.width,
        shadows=not args.no_shadows,
    )
    if args.sweep:
        lengths = [int(v) for v in args.sweep.split(",")]
        setting = (
            f"{len(cams)} camera(s) {','.join(cams)} at {args.height}x{args.width}, "
            f"shadows {'off' if args.no_shadows else 'on'}, {DEFAULT_COMPRESSION} compression"
            if cams
            else "no cameras (state only)"
        )
        print(f"recording cost against episode length, {setting}, best of {args.repeats}:")
        with tempfile.TemporaryDirectory() as tmp:
            points = sweep(settings, lengths, args.repeats, Path(tmp))
        if args.json:
            record = {
                "source": "benchmarks/record_episode.py --sweep",
                "setting": setting,
                "repeats": args.repeats,
                "measured": datetime.date.today().isoformat(),
                "machine": f"{os.cpu_count()} CPUs, {platform.processor() or platform.machine()}",
                "load_average_end": round(os.getloadavg()[0], 1),
                "points": points,
            }
            Path(args.json).write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
        return
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
        recorder.close()
        times = side_by_side(settings, actions, poses, out, args.block)
        floor_wall, floor_cpu = (v / steps for v in times["floor"])
        print(
            f"per rendered step ({len(cams)} frames), side by side in blocks of {args.block} "
            f"steps, load average now {os.getloadavg()[0]:.1f}:"
        )
        for name, (wall, cpu) in times.items():
            wall, cpu = wall / steps, cpu / steps
            label = "raw floor (Renderer + mj_step)" if name == "floor" else f"phase 2, {name}"
            print(
                f"  {label:32s} wall {wall * 1e3:7.1f} ms  ratio {wall / floor_wall:.3f}   "
                f"CPU {cpu * 1e3:7.1f} ms  ratio {cpu / floor_cpu:.3f}"
            )
        if args.marginal:
            lengths = tuple(int(v) for v in args.marginal.split(","))
            if len(lengths) != 2 or not 0 < lengths[0] < lengths[1] <= steps:
                parser.error(f"--marginal takes L1,L2 with 0 < L1 < L2 <= {steps}")
            per = marginal(settings, actions, poses, out, lengths, args.repeats)
            print(
                f"one more rendered step, steps {lengths[0]} -> {lengths[1]}, best of "
                f"{args.repeats}, load average now {os.getloadavg()[0]:.1f}:"
            )
            for name, (wall, cpu) in per.items():
                print(
                    f"  {name:8s} wall {wall * 1e3:7.1f} ms  ratio {wall / per['floor'][0]:.3f}"
                    f"   CPU {cpu * 1e3:7.1f} ms  ratio {cpu / per['floor'][1]:.3f}"
                )
        print(
            "vendor package, same settings, measured on a 2-core CPU: 38 min 13 s "
            f"(this run: {record_s / 2293:.3f}x of it)"
        )
        if not args.no_compression:
            print(f"compression (rewrite of the recorded frames, {steps} steps):")
            print(
                "  option   write (s)  deflate CPU/frame (ms)  deflate CPU/episode (s)  size (MB)  "
                "size/raw"
            )
            rows = compression_table(out / "episode_0.hdf5", out)
            raw = next(r[3] for r in rows if r[0] == "none")
            for label, seconds, cpu_ms, nbytes in rows:
                cpu = f"{cpu_ms:8.2f}" if cpu_ms else "       -"
                per_episode = f"{cpu_ms * frames / 1e3:8.1f}" if cpu_ms else "       -"
                print(
                    f"  {label:7s} {seconds:9.1f}  {cpu:>19s}  {per_episode:>20s}  "
                    f"{nbytes / 1e6:9.1f}  {nbytes / raw:7.3f}"
                )


if __name__ == "__main__":
    main()
