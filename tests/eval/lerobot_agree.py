"""Roll a LeRobot checkpoint through ``trossen-mujoco eval``'s own loop and print the joint
states it saw, one line ``RESULT <json>`` (run by test_lerobot_tools.py with the Python that has
LeRobot; never imported by the suite)::

    python lerobot_agree.py CHECKPOINT SEED EPISODE_LENGTH
"""

from __future__ import annotations

import json
import os
import sys

os.environ.setdefault("HF_HUB_OFFLINE", "1")
os.environ.setdefault("MUJOCO_GL", "egl")


def main() -> None:
    from trossen_arm_mujoco.eval.env import KitPolicyEnv
    from trossen_arm_mujoco.eval.lerobot_policy import LeRobotPolicy

    checkpoint, seed, length = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    env = KitPolicyEnv("sim_transfer_cube", episode_length=length, controller_checks=False)
    policy = LeRobotPolicy(checkpoint, env)
    obs, _ = env.reset(seed=seed)
    policy.reset(env, seed)
    states = []
    for _ in range(length):
        states.append(obs["agent_pos"].tolist())
        obs, *_ = env.step(policy.act(obs))
    env.close()
    print("RESULT " + json.dumps({"agent_pos": states}))


if __name__ == "__main__":
    main()
