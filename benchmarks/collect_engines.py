"""Episodes per hour of each collection engine, against raw MuJoCo, in one run.

    MUJOCO_GL=egl python benchmarks/collect_engines.py                    # 2-3 minutes
    MUJOCO_GL=egl python benchmarks/collect_engines.py --episodes 20 --state_episodes 100 \\
        --episode_len 600 --image_size 480x640                            # longer, documented size

For state-only recording and for one camera, records the same episodes with:

- ``local x1``: ``DatasetRecorder`` in this process (``--num_workers 1``);
- ``local x2``: two spawned worker processes (``--num_workers 2``), pool start-up included;
- ``ray x2``: a local Ray with 2 CPUs (``--engine ray``), the first tasks' worker start-up
  included (its workers then stay up for the camera case); starting the Ray instance itself
  is timed separately.

The floor, in the same run: bare ``mj_step`` for the physics steps of one episode's two phases
(joint scene), plus a bare ``mujoco.Renderer`` for its frames, on one core. Each engine's rate
is printed with its ratio to that single-core floor (2 workers can reach up to 2x on 2 free
cores). Every engine's files are checked to be identical.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from contextlib import ExitStack
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402

from trossen_arm_mujoco.collect.parallel import DatasetRecorder  # noqa: E402
from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings  # noqa: E402
from trossen_arm_mujoco.collect.resume import plan_run  # noqa: E402


def raw_floor_seconds(settings: RecordSettings, frames: int = 60, repeats: int = 3) -> float:
    """Seconds of bare MuJoCo for one episode: 2 x episode_len policy steps of mj_step on the
    joint scene, plus one render per step and camera (best of ``repeats`` over ``frames``
    frames, scaled to the episode)."""
    recorder = EpisodeRecorder(settings)
    model = recorder.joint_scene.model
    substeps = round(recorder.policy_dt / model.opt.timestep)
    recorder.close()
    data = mujoco.MjData(model)
    start = time.perf_counter()
    for _ in range(2 * settings.episode_len * substeps):
        mujoco.mj_step(model, data)
    seconds = time.perf_counter() - start
    if settings.cam_names:
        renderer = mujoco.Renderer(model, settings.height, settings.width)
        frames = min(frames, settings.episode_len)
        best = float("inf")
        for _ in range(repeats):
            start = time.perf_counter()
            for _ in range(frames):
                mujoco.mj_step(model, data)
                for cam in settings.cam_names:
                    renderer.update_scene(data, camera=cam)
                    renderer.render()
            best = min(best, time.perf_counter() - start)
        renderer.close()
        seconds += best * settings.episode_len / frames
    return seconds


def timed_run(recorder: DatasetRecorder, folder: Path, episodes: int) -> float:
    start = time.perf_counter()
    report = recorder.run(episodes, plan_run(folder, episodes, False))
    seconds = time.perf_counter() - start
    assert len(report.saved) == episodes, report
    return seconds


def same_files(a: Path, b: Path, episodes: int) -> bool:
    return all(
        (a / f"episode_{k}.hdf5").read_bytes() == (b / f"episode_{k}.hdf5").read_bytes()
        for k in range(episodes)
    )


def make_recorder(engine: str, settings: RecordSettings, folder: Path) -> DatasetRecorder:
    if engine == "ray x2":
        from trossen_arm_mujoco.collect.ray_engine import RayDatasetRecorder

        return RayDatasetRecorder(settings, folder, max_in_flight=2, log=lambda s: None)
    workers = int(engine[-1])
    return DatasetRecorder(settings, folder, num_workers=workers, log=lambda s: None)


def run_case(case: str, settings: RecordSettings, episodes: int, with_ray: bool) -> None:
    floor = raw_floor_seconds(settings)
    floor_rate = 3600.0 / floor
    print(
        f"\n{case}, {episodes} episodes per engine: raw MuJoCo floor {floor:.2f} s/episode "
        f"= {floor_rate:,.0f} episodes/h"
    )
    print(f"  {'engine':10s} {'wall s':>8s} {'episodes/h':>11s} {'ratio to floor':>15s}")
    engines = ["local x1", "local x2"] + (["ray x2"] if with_ray else [])
    with tempfile.TemporaryDirectory() as tmp:
        folders = []
        for engine in engines:
            folder = Path(tmp) / engine.replace(" ", "_")
            seconds = timed_run(make_recorder(engine, settings, folder), folder, episodes)
            rate = episodes / seconds * 3600.0
            print(f"  {engine:10s} {seconds:8.1f} {rate:11,.0f} {rate / floor_rate:15.3f}")
            folders.append(folder)
        identical = all(same_files(folders[0], f, episodes) for f in folders[1:])
        print(f"  files identical across engines: {identical}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--episodes", type=int, default=6, help="camera episodes per engine (default: 6)"
    )
    parser.add_argument(
        "--state_episodes", type=int, default=30, help="state-only episodes per engine"
    )
    parser.add_argument("--episode_len", type=int, default=200, help="steps per episode")
    parser.add_argument("--camera", default="cam_high", help="camera of the 1-camera case")
    parser.add_argument("--image_size", default="120x160", help="HEIGHTxWIDTH of that camera")
    parser.add_argument("--no_ray", action="store_true", help="local engines only")
    args = parser.parse_args()
    height, width = (int(v) for v in args.image_size.split("x"))
    cases = {
        "state only": (RecordSettings(episode_len=args.episode_len), args.state_episodes),
        f"1 camera {height}x{width}": (
            RecordSettings(
                episode_len=args.episode_len, cam_names=(args.camera,), height=height, width=width
            ),
            args.episodes,
        ),
    }
    print(
        f"episodes of {args.episode_len} steps; {os.cpu_count()} CPUs seen (shared with other "
        "work: compare within one run)"
    )

    with ExitStack() as stack:
        if not args.no_ray:
            from trossen_arm_mujoco.collect.ray_session import ray_session

            start = time.perf_counter()
            stack.enter_context(ray_session(None, num_cpus=2))
            print(f"local Ray start (2 CPUs): {time.perf_counter() - start:.1f} s (not counted)")
        for case, (settings, episodes) in cases.items():
            run_case(case, settings, episodes, with_ray=not args.no_ray)


if __name__ == "__main__":
    main()
