"""Batched IK / FK (``ParallelKinematics``) against a Python loop over the single solver.

    python benchmarks/parallel_kinematics.py                       # wxai arm, N = 1, 64, 1024
    python benchmarks/parallel_kinematics.py --robot kit --sizes 1 64 1024 --iterations 20
    python benchmarks/parallel_kinematics.py --clock cpu --repeats 5

For each batch size N, in one run and on the same targets (FK of N random valid joint
configurations, seeded) from the same initial joints (the robot's home pose):

1. ``fixed``: IK with exactly ``--iterations`` update steps per target (eps = 0, so no
   target stops early): ``ParallelKinematics.solve`` on the batch; a Python loop of
   ``RobotKinematics.solve_ik`` over the targets; and the raw MuJoCo floor of such a loop:
   the ``mj_kinematics`` + ``mj_comPos`` + ``mj_jacSite`` calls it makes, with no math in
   between. Both solvers must give the same joints (the max difference is printed).
2. ``converge``: IK to eps = 1e-6 (at most ``--max-iter`` steps): solves per second,
   success rate and mean iterations of the batched solver and the loop.
3. ``fk``: forward kinematics of the group's tool frame: ``ParallelKinematics.leaf_poses``
   on the batch, a loop of ``RobotKinematics.fk``, and the raw floor (qpos + ``mj_kinematics``).

Reported: solves (or FK evaluations) per second, best of ``--repeats`` interleaved runs,
and the ratios batched / loop and batched / floor (> 1: faster). BLAS is held to one thread
(set ``OPENBLAS_NUM_THREADS`` etc. to change that), so every number is single-core. On a
busy machine wall time is noisy: ``--clock cpu`` times this process's CPU time instead.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from trossen_arm_mujoco.constants import ASSETS_DIR  # noqa: E402
from trossen_arm_mujoco.robot import Robot  # noqa: E402
from trossen_arm_mujoco.robot.configs import stationary_ai_joint_config, wxai_config  # noqa: E402

CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}
ROBOTS = {  # name: (scene, config, IK group)
    "wxai": ("wxai/wxai_follower.xml", wxai_config, "arm"),
    "kit": ("stationary_ai/trossen_ai_scene_joint.xml", stationary_ai_joint_config, "left_arm"),
}


def best(fn, repeats: int, clock) -> tuple[float, object]:
    """(least time of ``repeats`` calls, the last result)."""
    times, out = [], None
    for _ in range(repeats):
        t0 = clock()
        out = fn()
        times.append(clock() - t0)
    return min(times), out


def raw_ik_floor(model, data, group, q0: np.ndarray, iterations: int) -> None:
    """The MuJoCo calls of a per-target IK loop (kinematics, COM, site Jacobian), no math."""
    jac_p, jac_r = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    adr, site = group.qpos_idx, group.leaf_frame_id
    for q in q0:
        for _ in range(iterations + 1):
            data.qpos[adr] = q
            mujoco.mj_kinematics(model, data)
            mujoco.mj_comPos(model, data)
            mujoco.mj_jacSite(model, data, jac_p, jac_r, site)


def raw_fk_floor(model, data, group, qs: np.ndarray) -> None:
    """The MuJoCo calls of a per-configuration FK loop."""
    adr = group.qpos_idx
    for q in qs:
        data.qpos[adr] = q
        mujoco.mj_kinematics(model, data)


def measure(robot: Robot, name: str, n: int, args, clock) -> dict[str, tuple]:
    """One table row per mode for batch size ``n``."""
    kin = robot.kinematics
    par = robot.get_parallel_kinematics(name)
    group = kin.robot_view.get_move_group(name)
    model, scratch = robot.model, mujoco.MjData(robot.model)
    limits = group.joint_pos_limits
    rng = np.random.default_rng(args.seed)
    q_true = rng.uniform(limits[:, 0], limits[:, 1], size=(n, len(limits)))
    poses = par.leaf_poses(q_true)
    q0 = np.tile(robot.robot_view.get_move_group(name).joint_pos, (n, 1))  # home pose
    par.warmup_ik(n)

    def loop(eps: float, max_iter: int) -> list:
        return [
            kin.solve_ik(name, poses[i], q0={name: q0[i]}, eps=eps, max_iter=max_iter)
            for i in range(n)
        ]

    rows = {}
    k, m, r = args.iterations, args.max_iter, args.repeats
    t_batch, batched = best(lambda: par.solve(poses, q0, eps=0.0, max_iter=k), r, clock)
    t_loop, looped = best(lambda: loop(0.0, k), r, clock)
    t_floor, _ = best(lambda: raw_ik_floor(model, scratch, group, q0, k), r, clock)
    diff = max(np.abs(batched.q[i] - res.qpos[name]).max() for i, res in enumerate(looped))
    rows["fixed"] = (
        n / t_batch,
        n / t_loop,
        n / t_floor,
        t_loop / t_batch,
        t_floor / t_batch,
        diff,
    )

    t_batch, batched = best(lambda: par.solve(poses, q0, eps=1e-6, max_iter=m), r, clock)
    t_loop, looped = best(lambda: loop(1e-6, m), r, clock)
    ok_loop = np.mean([res.converged for res in looped])
    rows["converge"] = (
        n / t_batch,
        n / t_loop,
        t_loop / t_batch,
        batched.converged.mean(),
        ok_loop,
        batched.iterations.mean(),
    )

    t_batch, _ = best(lambda: par.leaf_poses(q_true), r, clock)
    t_loop, _ = best(lambda: [kin.fk({name: q}) for q in q_true], r, clock)
    t_floor, _ = best(lambda: raw_fk_floor(model, scratch, group, q_true), r, clock)
    rows["fk"] = (n / t_batch, n / t_loop, n / t_floor, t_loop / t_batch, t_floor / t_batch)
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robot", choices=sorted(ROBOTS), default="wxai")
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 64, 1024])
    parser.add_argument("--iterations", type=int, default=20, help="IK steps in 'fixed'")
    parser.add_argument("--max-iter", type=int, default=100, help="IK step cap in 'converge'")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--clock", choices=sorted(CLOCKS), default="wall")
    args = parser.parse_args(argv)
    if min(args.sizes) < 1 or args.iterations < 1 or args.repeats < 1 or args.max_iter < 1:
        parser.error("sizes, --iterations, --max-iter and --repeats must be >= 1")
    clock = CLOCKS[args.clock]

    scene, make_config, name = ROBOTS[args.robot]
    model = mujoco.MjModel.from_xml_path(str(Path(ASSETS_DIR) / scene))
    robot = Robot(mujoco.MjData(model), make_config())
    robot.reset()
    dim = robot.robot_view.get_move_group(name).pos_dim
    print(
        f"robot {args.robot}, IK of '{name}' ({dim} joints), damping 1e-3, max_step 0.2 rad; "
        f"{args.clock} clock, best of {args.repeats}; mujoco {mujoco.__version__}, numpy "
        f"{np.__version__}, BLAS threads {os.environ['OPENBLAS_NUM_THREADS']}"
    )
    rows = {n: measure(robot, name, n, args, clock) for n in args.sizes}

    print(f"\nfixed: IK, {args.iterations} steps per target (eps = 0), solves per second")
    print(
        "     N |   batched |      loop | raw MuJoCo floor | batched/loop | batched/floor | max dq"
    )
    for n, row in rows.items():
        b, loop, floor, r1, r2, diff = row["fixed"]
        print(
            f"{n:6d} | {b:9.0f} | {loop:9.0f} | {floor:16.0f} | {r1:12.2f} | {r2:13.2f} | "
            f"{diff:.0e}"
        )
    print(f"\nconverge: IK to |error| < 1e-6 (m + rad), at most {args.max_iter} steps")
    print("     N |   batched |      loop | batched/loop | converged batched, loop | mean steps")
    for n, row in rows.items():
        b, loop, r1, ok_b, ok_l, steps = row["converge"]
        print(
            f"{n:6d} | {b:9.0f} | {loop:9.0f} | {r1:12.2f} | {ok_b:15.3f}, {ok_l:.3f} | "
            f"{steps:10.1f}"
        )
    print("\nfk: tool-frame pose, evaluations per second")
    print("     N |   batched |      loop | raw mj_kinematics | batched/loop | batched/floor")
    for n, row in rows.items():
        b, loop, floor, r1, r2 = row["fk"]
        print(f"{n:6d} | {b:9.0f} | {loop:9.0f} | {floor:17.0f} | {r1:12.2f} | {r2:13.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
