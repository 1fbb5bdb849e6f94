"""Success rate of the scripted transfer policy over many seeds (no images).

    python benchmarks/scripted_success.py --episodes 200            # without noise
    python benchmarks/scripted_success.py --episodes 200 --noise    # with noise

Runs both phases per seed (scripted mocap rollout, joint replay) exactly as recording does,
without cameras, and prints successes, the rate and the wall time. Target: >= 99 % without
noise, >= 90 % with noise.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from tqdm import tqdm

from trossen_arm_mujoco.collect.pipeline import EpisodeRecorder, RecordSettings, episode_seed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--noise", action="store_true")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episode_len", type=int, default=600)
    args = parser.parse_args()

    settings = RecordSettings(
        episode_len=args.episode_len, inject_noise=args.noise, base_seed=args.seed
    )
    recorder = EpisodeRecorder(settings)
    start = time.perf_counter()
    ee_ok = joint_ok = 0
    failed = []
    for k in tqdm(range(args.episodes), desc="episodes"):
        rng = np.random.default_rng(episode_seed(args.seed, k))
        actions, box_pose = recorder.scripted_rollout(rng)
        ee_ok += int(recorder.ee_env.task.get_reward(recorder.ee_env.physics) == 4)
        rewards = recorder.replay(actions, box_pose)
        if rewards[-1] == 4:
            joint_ok += 1
        else:
            failed.append(k)
    wall = time.perf_counter() - start
    recorder.close()
    n = args.episodes
    print(f"noise={args.noise} episodes={n} wall={wall:.1f}s ({wall / n:.2f}s/episode)")
    print(f"phase 1 (EE env) success:    {ee_ok}/{n} = {100 * ee_ok / n:.1f}%")
    print(f"phase 2 (joint env) success: {joint_ok}/{n} = {100 * joint_ok / n:.1f}%")
    if failed:
        print(f"failed attempts: {failed}")


if __name__ == "__main__":
    main()
