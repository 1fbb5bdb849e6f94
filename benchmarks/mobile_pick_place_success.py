"""Success rate of the Mobile AI's scripted pick-and-place policy over many seeds (no images).

    python benchmarks/mobile_pick_place_success.py --episodes 50            # without noise
    python benchmarks/mobile_pick_place_success.py --episodes 50 --noise    # with noise

Each episode is what ``record --task_name mobile_pick_place --seed 0`` records as attempt
``i`` (the same seed, start pose, cube and policy), without cameras and without a file: the
policy acts on the task's observation for the task's recording length. Prints one line per
episode (stage reached, steps at which each stage was first reached, base commands clipped),
then the success count, the rate with its 95 % Wilson interval, each stage's rate and the
wall time.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from trossen_arm_mujoco.collect.pipeline import episode_seed
from trossen_arm_mujoco.eval.scores import wilson_interval
from trossen_arm_mujoco.policies.mobile_pick_place import MobilePickPlacePolicy
from trossen_arm_mujoco.robot.layout import MOBILEAI_LAYOUT
from trossen_arm_mujoco.tasks import registry

NAME = "mobile_pick_place"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=50)
    parser.add_argument("--seed", type=int, default=0, help="base seed, as record --seed")
    parser.add_argument("--first", type=int, default=0, help="first attempt (split a run)")
    parser.add_argument("--noise", action="store_true", help="as record --inject_noise")
    args = parser.parse_args()
    entry = registry.load(NAME)
    stages = registry.stages(NAME)
    steps = int(entry.record["episode_len"])
    reached = {stage: 0 for stage in stages}
    successes = 0
    start = time.perf_counter()
    with registry.make_sampler(NAME) as sampler:
        for attempt in range(args.first, args.first + args.episodes):
            rng = np.random.default_rng(episode_seed(args.seed, attempt))
            task = sampler.next_task(rng)
            policy = MobilePickPlacePolicy(task, inject_noise=args.noise, rng=rng)
            obs, rewards = task.get_observation(), np.empty(steps)
            for t in range(steps):
                obs, rewards[t], _ = task.step(MOBILEAI_LAYOUT.commands(policy(obs)))
            success = bool(task.judge_success())
            successes += success
            firsts = {}
            for stage, level in stages.items():
                hit = rewards >= level
                reached[stage] += bool(hit.any())
                firsts[stage] = int(np.argmax(hit)) if hit.any() else None
            clipped = task.robot.controllers["base"].clipped_commands
            print(
                f"episode {attempt}: success={success} final reward {rewards[-1]:g}, first "
                f"step per stage {firsts}, base commands clipped {clipped}",
                flush=True,
            )
    n = args.episodes
    low, high = wilson_interval(successes, n)
    print(
        f"{NAME}{' with noise' if args.noise else ''}: {successes}/{n} successes "
        f"({100 * successes / n:.0f} %, 95 % interval {low:.0f}-{high:.0f} %); "
        + ", ".join(f"{s} {100 * c / n:.0f} %" for s, c in reached.items())
        + f"; {time.perf_counter() - start:.0f} s"
    )


if __name__ == "__main__":
    main()
