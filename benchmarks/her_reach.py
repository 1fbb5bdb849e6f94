"""SAC + HER on ``TrossenMujoco/WXAIReachGoal-v0`` (state observations, ee_delta actions).

Trains in chunks and evaluates the deterministic policy on a fixed set of episodes after
each chunk; stops at the first evaluation with a success rate >= ``--target`` and prints the
environment steps and wall time it took.

    python benchmarks/her_reach.py --total-steps 30000 --eval-every 2000 --eval-episodes 50

Needs the ``rl`` extra (stable-baselines3 and torch).
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import torch
from stable_baselines3 import SAC, HerReplayBuffer

import trossen_arm_mujoco  # noqa: F401  (registers the env ids; state envs open no GL)

ENV_ID = "TrossenMujoco/WXAIReachGoal-v0"
EVAL_SEED_OFFSET = 1_000_000


def evaluate(model, env: gym.Env, episodes: int, seed: int) -> float:
    """Success rate of the deterministic policy over ``episodes`` seeded episodes."""
    successes = 0
    for i in range(episodes):
        obs, _ = env.reset(seed=seed + EVAL_SEED_OFFSET + i)
        done = False
        info: dict = {}
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        successes += bool(info.get("is_success", False))
    return successes / episodes


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--total-steps", type=int, default=50_000, help="training step budget")
    p.add_argument("--eval-every", type=int, default=2_000, help="steps between evaluations")
    p.add_argument("--eval-episodes", type=int, default=50, help="episodes per evaluation")
    p.add_argument("--target", type=float, default=0.9, help="success rate to reach")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--learning-starts", type=int, default=1_000)
    p.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    torch.set_num_threads(args.threads)
    env = gym.make(ENV_ID, action_mode="ee_delta")
    eval_env = gym.make(ENV_ID, action_mode="ee_delta")
    model = SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future"},
        learning_starts=args.learning_starts,
        learning_rate=1e-3,
        batch_size=256,
        gamma=0.95,
        tau=0.05,
        policy_kwargs={"net_arch": [256, 256]},
        seed=args.seed,
        device="cpu",
        verbose=0,
    )
    print(
        f"{ENV_ID}: SAC + HER, seed {args.seed}, target {args.target:.0%} over "
        f"{args.eval_episodes} episodes"
    )
    start = time.perf_counter()
    steps, rate, train_s = 0, 0.0, 0.0
    while steps < args.total_steps:
        chunk = min(args.eval_every, args.total_steps - steps)
        t0 = time.perf_counter()
        model.learn(total_timesteps=chunk, reset_num_timesteps=False)
        train_s += time.perf_counter() - t0
        steps += chunk
        rate = evaluate(model, eval_env, args.eval_episodes, args.seed)
        print(f"steps {steps:7d}  success {rate:6.1%}  training {train_s:7.1f} s", flush=True)
        if rate >= args.target:
            print(
                f"reached {rate:.1%} >= {args.target:.0%} after {steps} steps, "
                f"{train_s:.1f} s of training wall time "
                f"({time.perf_counter() - start:.1f} s including evaluations)"
            )
            return 0
    print(f"not reached: {rate:.1%} after {steps} steps, {time.perf_counter() - start:.1f} s")
    return 1


if __name__ == "__main__":
    raise SystemExit(main())
