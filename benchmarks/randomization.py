"""Cost of domain randomization per episode and of the per-link safety floor per step,
against raw MuJoCo on the same model.

    MUJOCO_GL=egl python benchmarks/randomization.py               # 200 episodes per task
    MUJOCO_GL=egl python benchmarks/randomization.py --episodes 500 --clock cpu

For every registered task it times, state only (no rendering):

- ``randomize_scene``: sampling and applying one randomization (every kind on, as in the
  task's YAML), restoring the nominal scene first, as every episode does;
- ``sample_task`` with and without randomization (reset, randomize, place objects, build
  and reset the task): the per-episode overhead is their difference;
- the floor: one episode's physics, ``max_episode_steps * policy_dt / sim_dt`` raw
  ``mujoco.mj_step`` calls on the same model; the ratio is randomize_scene / that.

and for the gym env of every task, the action mapping and one control tick with the safety
floor (``ActionMapper`` call: normalization; then the robot's ``update_control`` and
``apply_control``: rate limits, IK for ``ee_delta``, the per-link forward-kinematics check of
``robot.safety_floor``) in each action mode, in microseconds and as a fraction of one policy
step's raw physics (``policy_dt / sim_dt`` ``mj_step`` calls). The best of ``--repeats``
runs is kept.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from trossen_arm_mujoco.tasks.sampler_settings import SamplerSettings

CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def best(fn, n: int, repeats: int, clock) -> float:
    """Best time per call (s) of ``fn(i)`` over ``n`` calls, of ``repeats`` runs."""
    times = []
    for _ in range(repeats):
        start = clock()
        for i in range(n):
            fn(i)
        times.append((clock() - start) / n)
    return min(times)


def mj_step_time(model: mujoco.MjModel, n: int, repeats: int, clock) -> float:
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)
    return best(lambda _: mujoco.mj_step(model, data), n, repeats, clock)


def episode_row(name: str, args, clock) -> str:
    from trossen_arm_mujoco.tasks import registry

    on = registry.make_sampler(name, SamplerSettings(randomize=True))
    off = registry.make_sampler(name)
    view = on.robot_view
    on.sample_task(0)
    t_rand = best(lambda i: on.randomize_scene(on.scene, view), args.episodes, args.repeats, clock)
    t_on = best(lambda i: on.sample_task(i), args.episodes, args.repeats, clock)
    t_off = best(lambda i: off.sample_task(i), args.episodes, args.repeats, clock)
    probe = on.make_task()
    steps = int(probe.max_episode_steps) * round(probe.policy_dt / on.scene.sim_dt)
    physics = mj_step_time(on.scene.model, 2000, args.repeats, clock) * steps
    on.close()
    off.close()
    return (
        f"{name:20s} {t_rand * 1e6:15.0f}  {t_off * 1e6:15.0f}  {t_on * 1e6:14.0f}  "
        f"{physics * 1e6:15.0f}  {t_rand / physics:19.4f}"
    )


def action_time(env_id: str, mode: str, args, clock) -> str:
    import gymnasium as gym

    import trossen_arm_mujoco  # noqa: F401  (registers the ids)

    env = gym.make(env_id, action_mode=mode)
    env.reset(seed=0)
    u = env.unwrapped
    acts = np.random.default_rng(0).uniform(-1, 1, size=(args.steps, env.action_space.shape[0]))
    data = u.scene.data
    robot = u.task.robot

    def tick(i: int) -> None:
        robot.update_control(u.actions(data, acts[i]))
        robot.apply_control(data)

    t = best(tick, args.steps, args.repeats, clock)
    n_phys = round(u.task.policy_dt / u.scene.sim_dt)
    t_phys = mj_step_time(u.scene.model, 2000, args.repeats, clock) * n_phys
    env.close()
    return f"{mode} {t * 1e6:6.1f} ({t / t_phys:.2f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall")
    args = parser.parse_args()
    clock = CLOCKS[args.clock]
    from trossen_arm_mujoco.gym.registration import ENV_IDS
    from trossen_arm_mujoco.tasks import registry

    print(
        "per episode (us)      randomize_scene  sample_task off  sample_task on  "
        "episode physics  randomize / physics"
    )
    for name in registry.names():
        print(episode_row(name, args, clock), flush=True)
    print(
        "\naction mapping and a control tick with the safety floor, per step (us; fraction "
        "of a step's physics)"
    )
    tasks = {task: env_id for env_id, (_, task, _) in reversed(ENV_IDS.items())}
    for task, env_id in sorted(tasks.items()):
        modes = ("joint_position", "joint_rel_position", "ee_delta")
        print(
            f"{task:20s} " + "   ".join(action_time(env_id, m, args, clock) for m in modes),
            flush=True,
        )


if __name__ == "__main__":
    main()
