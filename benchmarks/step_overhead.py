"""Stepping cost of every env against a raw ``mujoco.mj_step`` loop on the same model.

    MUJOCO_GL=egl python benchmarks/step_overhead.py              # 1000 steps per env
    MUJOCO_GL=egl python benchmarks/step_overhead.py --steps 3000 --repeats 5

For every gymnasium id of ``gym.registration.ENV_IDS`` (state observations, the default
action mode, and ``ee_delta`` for the plain envs) and for the two dm_control envs
(``make_sim_env(TransferCubeTask, cam_list=[])`` and ``make_sim_env(TransferCubeEETask,
cam_list=[])``), it

1. runs the env once untimed, recording the initial state of every episode and the controls
   (``ctrl`` and mocap poses) of every step: gym envs take uniform random actions (episodes
   end by the registered TimeLimit and are reset), the dm_control EE env runs the scripted
   transfer policy, the joint env replays the EE run's joint trajectory (as recording does);
2. times the same run again (same seed, same actions: the same trajectory), resets included;
3. times the floor: a bare loop that loads the recorded states and controls into a fresh
   ``MjData`` of the same model and calls ``mujoco.mj_step`` for the same number of
   physics steps (the same simulated trajectory, with no Python in between).

Both are reported as simulated seconds per wall second; ``ratio`` = floor / env (1.0 = no
overhead). The best of ``--repeats`` interleaved runs of each is kept. Each env is measured in
a fresh Python process (``--in-process``: all in this one, one after the other; the envs
measured first then shift later figures by a few hundredths). On a busy machine wall
time is noisy: ``--clock cpu`` times with this process's CPU time instead (less sensitive to
other processes; the same as wall time on an idle machine).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from dataclasses import dataclass

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}
clock = time.perf_counter  # set by --clock

USER = mujoco.mjtState.mjSTATE_USER  # ctrl, applied forces, eq_active, mocap poses
FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


@dataclass
class Recording:
    """What the floor replays: episode start states and per-step controls."""

    model: mujoco.MjModel
    starts: dict[int, np.ndarray]  # step index -> full physics state at the episode start
    controls: np.ndarray  # (steps, user state size)
    physics_steps: int  # physics steps per env step
    policy_dt: float  # simulated seconds per env step


def get_state(model, data, spec) -> np.ndarray:
    out = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, out, spec)
    return out


def floor_time(rec: Recording) -> float:
    """Wall seconds of the bare mj_step loop over the recorded trajectory."""
    model = rec.model
    data = mujoco.MjData(model)
    n = rec.physics_steps
    starts, controls = rec.starts, rec.controls
    t0 = clock()
    for i in range(len(controls)):
        if i in starts:
            mujoco.mj_setState(model, data, starts[i], FULL)
        mujoco.mj_setState(model, data, controls[i], USER)
        mujoco.mj_step(model, data, n)
    return clock() - t0


# -- gymnasium envs ---------------------------------------------------------------------------
def gym_run(env_id: str, steps: int, record: bool, **kwargs) -> tuple[float, Recording | None]:
    """(wall seconds of ``steps`` random steps with resets, recording or None)."""
    import gymnasium as gym

    env = gym.make(env_id, **kwargs)
    try:
        env.reset(seed=0)
        rng = np.random.default_rng(0)
        actions = rng.uniform(-1, 1, (steps, *env.action_space.shape)).astype(np.float32)
        base = env.unwrapped
        model, data = base.scene.model, base.scene.data
        starts: dict[int, np.ndarray] = {}
        controls = np.empty((steps, mujoco.mj_stateSize(model, USER))) if record else None
        env.reset(seed=0)
        if record:
            starts[0] = get_state(model, data, FULL)
        t0 = clock()
        for i in range(steps):
            _, _, terminated, truncated, _ = env.step(actions[i])
            if record:
                mujoco.mj_getState(model, data, controls[i], USER)
            if terminated or truncated:
                env.reset()
                if record:
                    starts[i + 1] = get_state(model, data, FULL)
        wall = clock() - t0
        rec = None
        if record:
            probe = base.probe
            n = probe.n_ctrl_steps * base.scene.n_substeps
            rec = Recording(model, starts, controls, n, probe.policy_dt)
        return wall, rec
    finally:
        env.close()


# -- dm_control envs --------------------------------------------------------------------------
def dm_actions(steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(EE actions of the scripted policy, joint actions from that rollout, initial cube
    pose), seed 0 (as phase 1 of recording builds them)."""
    from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask
    from trossen_arm_mujoco.scripted_policy import PickAndTransferPolicy
    from trossen_arm_mujoco.sim_env import TransferCubeTask
    from trossen_arm_mujoco.utils import make_sim_env

    env = make_sim_env(TransferCubeEETask, cam_list=[], random=0, time_limit=steps * 0.1)
    ts = env.reset()
    box_pose = np.asarray(ts.observation["env_state"], dtype=float).copy()
    policy = PickAndTransferPolicy(inject_noise=False)
    ee = np.empty((steps, 16))
    joint = np.empty((steps, 16))
    for t in range(steps):
        ee[t] = policy(ts)
        ts = env.step(ee[t])
        joint[t] = ts.observation["qpos"]
        joint[t, 6:8] = ee[t, 7]
        joint[t, 14:16] = ee[t, 15]
    joint_env = make_sim_env(TransferCubeTask, cam_list=[])
    low, high = joint_env.task.action_bounds(joint_env.physics)
    return ee, np.clip(joint, low, high), box_pose


def dm_run(
    kind: str, actions: np.ndarray, box_pose: np.ndarray, record: bool
) -> tuple[float, Recording | None]:
    """(wall seconds of the dm_control env stepping through ``actions``, recording or None)."""
    from trossen_arm_mujoco.ee_sim_env import TransferCubeEETask
    from trossen_arm_mujoco.sim_env import TransferCubeTask
    from trossen_arm_mujoco.utils import make_sim_env

    steps = len(actions)
    limit = steps * 0.1
    if kind == "ee":
        env = make_sim_env(TransferCubeEETask, cam_list=[], random=0, time_limit=limit)
    else:
        env = make_sim_env(TransferCubeTask, cam_list=[], time_limit=limit, box_pose=box_pose)
    model, data = env.physics.model.ptr, env.physics.data.ptr
    env.reset()
    starts = {0: get_state(model, data, FULL)} if record else {}
    controls = np.empty((steps, mujoco.mj_stateSize(model, USER))) if record else None
    t0 = clock()
    for i in range(steps):
        env.step(actions[i])
        if record:
            mujoco.mj_getState(model, data, controls[i], USER)
    wall = clock() - t0
    rec = None
    if record:
        dt = env.control_timestep()
        n = int(round(dt / model.opt.timestep))
        rec = Recording(model, starts, controls, n, dt)
    return wall, rec


# -- driver -----------------------------------------------------------------------------------
def measure(name: str, run, repeats: int) -> dict:
    """Best-of-``repeats`` env and floor rates for one env (``run(record) -> (wall, rec)``)."""
    _, rec = run(True)
    env_wall, floor_wall = np.inf, np.inf
    for _ in range(repeats):  # interleaved, so both see the same machine load
        env_wall = min(env_wall, run(False)[0])
        floor_wall = min(floor_wall, floor_time(rec))
    sim_s = len(rec.controls) * rec.policy_dt
    env_rate, floor_rate = sim_s / env_wall, sim_s / floor_wall
    return {"name": name, "env": env_rate, "raw": floor_rate, "ratio": floor_rate / env_rate}


def _cases(args) -> list[tuple[str, object]]:
    """(label, run) of every env: ``run(record) -> (wall, recording)``."""
    import trossen_arm_mujoco  # noqa: F401  (registers the ids)
    from trossen_arm_mujoco.gym.registration import ENV_IDS

    cases = []
    for env_id, (entry, _task, _kw) in ENV_IDS.items():
        for kw in ({}, {"action_mode": "ee_delta"}) if not entry.endswith("GoalEnv") else ({},):
            name = env_id.split("/")[-1] + (f" {kw['action_mode']}" if kw else "")

            def run(record, env_id=env_id, kw=kw):
                return gym_run(env_id, args.steps, record, obs_type="state", **kw)

            cases.append((name, run))
    dm_actions_cache: dict = {}
    for kind, label in (
        ("joint", "dm_control TransferCubeTask (joint)"),
        ("ee", "dm_control TransferCubeEETask (mocap)"),
    ):

        def run(record, kind=kind):
            if not dm_actions_cache:
                dm_actions_cache["v"] = dm_actions(args.dm_steps)
            ee_actions, joint_actions, box_pose = dm_actions_cache["v"]
            actions = ee_actions if kind == "ee" else joint_actions
            return dm_run(kind, actions, box_pose, record)

        cases.append((label, run))
    return cases


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=1000, help="env steps per gym env")
    p.add_argument("--dm-steps", type=int, default=600, help="env steps per dm_control env")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per env (best kept)")
    p.add_argument("--only", default="", help="run only envs whose name contains this")
    p.add_argument("--clock", choices=sorted(CLOCKS), default="wall", help="what to time")
    p.add_argument(
        "--in-process",
        action="store_true",
        help="measure every env in this process, one after the other (default: each env in "
        "a fresh Python process, so figures do not depend on the envs measured before)",
    )
    p.add_argument("--case", type=int, default=None, help=argparse.SUPPRESS)  # one, as JSON
    args = p.parse_args(argv)
    global clock
    clock = CLOCKS[args.clock]
    cases = _cases(args)
    if args.case is not None:
        name, run = cases[args.case]
        print("ROW " + json.dumps(measure(name, run, args.repeats)))
        return
    passed = [
        "--steps",
        str(args.steps),
        "--dm-steps",
        str(args.dm_steps),
        "--repeats",
        str(args.repeats),
        "--clock",
        args.clock,
    ]
    rows = []
    for index, (name, run) in enumerate(cases):
        if args.only not in name:
            continue
        if args.in_process:
            rows.append(measure(name, run, args.repeats))
        else:
            done = subprocess.run(
                [sys.executable, os.path.abspath(__file__), "--case", str(index), *passed],
                capture_output=True,
                text=True,
                check=False,
            )
            lines = [x for x in done.stdout.splitlines() if x.startswith("ROW ")]
            if done.returncode != 0 or not lines:
                last = (done.stderr.strip().splitlines() or ["no output"])[-1]
                sys.exit(f"measuring {name} failed: {last}")
            rows.append(json.loads(lines[-1][4:]))
        _print_row(rows[-1])
    print()
    unit = "sim s/s" if args.clock == "wall" else "sim s/cpu s"
    print(f"| {'env':<46} | {'env ' + unit:>15} | {'raw ' + unit:>15} | {'ratio':>5} |")
    print(f"|{'-' * 48}|{'-' * 17}|{'-' * 17}|{'-' * 7}|")
    for r in rows:
        print(f"| {r['name']:<46} | {r['env']:>15.1f} | {r['raw']:>15.1f} | {r['ratio']:>5.2f} |")


def _print_row(r: dict) -> None:
    print(
        f"{r['name']:<46} env {r['env']:8.1f} sim s/s   raw {r['raw']:8.1f} sim s/s   "
        f"ratio {r['ratio']:.2f}",
        flush=True,
    )


if __name__ == "__main__":
    main()
