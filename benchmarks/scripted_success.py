"""Success rate of the scripted transfer policy over many seeds (no images).

    python benchmarks/scripted_success.py --episodes 200            # without noise
    python benchmarks/scripted_success.py --episodes 200 --noise    # with noise
    python benchmarks/scripted_success.py --task sim_insertion --episodes 100 [--noise]
    python benchmarks/scripted_success.py --episodes 100 --randomize  # domain randomization

Runs both phases per seed (scripted mocap rollout, joint replay) exactly as recording does,
without cameras, and prints successes, the rate and the wall time, plus how close the
recordings come to the real arm's speed limits: the largest commanded speed between
consecutive actions at the 50 Hz recording rate, the largest measured joint and finger speed
in the joint replay (both as a fraction of the URDF limits), how many action values the
recorder had to rate-limit, and how many episodes pass the real-replay validator at 50 fps.
Targets: >= 99 % without noise, >= 97 % with noise; every speed fraction <= 1.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from tqdm import tqdm

from trossen_arm_mujoco.collect.pipeline import (
    ACTION_SPEED_LIMITS,
    EpisodeRecorder,
    RecordSettings,
    episode_seed,
)

LABELS = ["j0", "j1", "j2", "j3", "j4", "j5", "finger_r", "finger_l"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="sim_transfer_cube", help="a task with a scripted policy")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--noise", action="store_true")
    parser.add_argument("--randomize", action="store_true", help="domain randomization")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--episode_len", type=int, default=None, help="default: the task's recording default"
    )
    args = parser.parse_args()

    measured = np.zeros(16)

    def track(_t: int, obs: dict, _scene) -> None:
        np.maximum(measured, np.abs(obs["qvel"]) / ACTION_SPEED_LIMITS, out=measured)

    from trossen_arm_mujoco.tasks import registry

    episode_len = args.episode_len or registry.load(args.task).record["episode_len"]
    settings = RecordSettings(
        task_name=args.task,
        episode_len=episode_len,
        inject_noise=args.noise,
        base_seed=args.seed,
        randomize=args.randomize,
    )
    recorder = EpisodeRecorder(settings, step_hook=track)
    start = time.perf_counter()
    ee_ok = joint_ok = validated = limited = 0
    commanded = np.zeros(16)
    failed = []
    for k in tqdm(range(args.episodes), desc="episodes", mininterval=5.0):
        rng = np.random.default_rng(episode_seed(args.seed, k))
        actions, box_pose = recorder.scripted_rollout(rng)
        limited += recorder.last_speed_limited
        ee_ok += int(recorder.scripted_success())
        speeds = np.abs(np.diff(actions, axis=0)) * recorder.fps / ACTION_SPEED_LIMITS
        np.maximum(commanded, speeds.max(axis=0), out=commanded)
        validated += int(recorder.check_real_replay(actions)[0])
        rewards = recorder.replay(actions, box_pose)
        if rewards[-1] == recorder.max_reward:
            joint_ok += 1
        else:
            failed.append(k)
    wall = time.perf_counter() - start
    recorder.close()
    n = args.episodes
    print(
        f"task={args.task} noise={args.noise} randomize={args.randomize} episodes={n} "
        f"wall={wall:.1f}s"
    )
    print(f"per episode: {wall / n:.2f} s")
    print(f"phase 1 (EE env) success:    {ee_ok}/{n} = {100 * ee_ok / n:.1f}%")
    print(f"phase 2 (joint env) success: {joint_ok}/{n} = {100 * joint_ok / n:.1f}%")
    print(f"real-replay validator at {recorder.fps:g} fps: {validated}/{n} pass")
    print(f"action values rate-limited by the recorder: {limited}")
    for name, fractions in (("commanded", commanded), ("measured", measured)):
        per_joint = np.maximum(fractions[:8], fractions[8:])  # worst of both arms
        cells = "  ".join(f"{lab} {v:.2f}" for lab, v in zip(LABELS, per_joint))
        print(f"peak {name} speed / limit: {cells}")
    if failed:
        print(f"failed attempts: {failed}")


if __name__ == "__main__":
    main()
