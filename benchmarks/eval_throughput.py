"""Evaluation throughput: ``KitPolicyEnv`` steps per second against raw MuJoCo, and its
scaling over worker processes.

    MUJOCO_GL=egl python benchmarks/eval_throughput.py      # cam_high at 96x128, 300 steps
    MUJOCO_GL=egl python benchmarks/eval_throughput.py --cams cam_high,cam_low --workers 1,2,4

Policy inference is excluded: the "policy" replays a fixed action array (a smooth motion
around the start pose, in the kit's 14-value layout), so what is timed is what an
evaluation pays per step besides the network: ``env.step`` (action checks, the
controllers, physics, the reward, the observation with its images).

1. env: ``--steps`` calls of ``env.step`` after ``env.reset(seed=0)`` (untimed).
2. raw floor, in the same run on the same ``MjModel``: a fresh ``MjData`` set to the env's
   start state, then per step the controls the env applied (recorded in an untimed run),
   ``n_ctrl_steps`` times ``mujoco.mj_step(model, data, n_substeps)`` (the same number of
   physics steps), and ``mujoco.Renderer.render()`` of the same cameras at the same size,
   with the shadow map size the env's cameras use at that size (``sim.cameras``; set when
   the renderer is made). No project code runs in that loop; its last image is checked
   against the env's (the same trajectory, the same pixels).
3. scaling: N spawned worker processes, each with its own env, wait at a barrier, then each
   runs ``--steps`` steps; total steps/s = N * steps / (last end - first start).

Env and floor alternate ``--repeats`` times (so both see the same machine load); the best
of each is kept. Prints steps/s, ms per step and the ratio env/raw (1.0 = no overhead), then
total steps/s, speedup and efficiency per worker count.

4. a policy (``--policy``: a LeRobot checkpoint folder, run in LeRobot's Python >= 3.12, or
   ``scripted``; replaces 1-3): ``eval.runner.evaluate`` over ``--episodes`` episodes of
   ``--episode_length`` steps at each worker count, with its thread split (each worker's
   torch and BLAS get max(1, cores // workers) threads). Prints episodes/s in the steady
   state (over the second half of the results, when every worker is running: spawning the
   workers and loading the policy excluded) and over the whole call, and both ratios
   against the first count (goal: 2 workers >= 1.7x one over the whole call). The counts
   run one after the other in this process, so a later count's parent finds torch and
   LeRobot imported; ``--fresh`` runs each count in a new process instead (each whole call
   pays its imports, as a ``trossen-mujoco eval`` run does). ``--controller_checks off``
   lets an untrained checkpoint (whose first action faults) run its episodes to the end::

       python benchmarks/eval_throughput.py --policy .../pretrained_model --workers 1,2
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import subprocess
import sys
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def replay_actions(steps: int) -> np.ndarray:
    """The fixed action array the replay "policy" plays: (steps, 14), a slow sway of every
    joint around the start pose, the grippers opening and closing."""
    from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, START_ARM_POSE

    start = KIT14_LAYOUT.from_vendor(np.asarray(START_ARM_POSE))
    t = np.arange(steps)[:, None] * 0.02
    phase = np.linspace(0, np.pi, 14)[None, :]
    actions = start + 0.3 * np.sin(2 * np.pi * 0.5 * t + phase)
    actions[:, [6, 13]] = 0.022 + 0.02 * np.cos(2 * np.pi * 0.5 * t[:, 0])[:, None]
    return actions


def make_env(args):
    from trossen_arm_mujoco.eval.env import KitPolicyEnv

    return KitPolicyEnv(
        args.task,
        cam_names=args.cam_list,
        image_size=args.size,
        episode_length=max(args.steps, 1),
        render_mode=None,
    )


def env_time(env, actions: np.ndarray) -> float:
    """Wall seconds of ``len(actions)`` env steps after an untimed reset."""
    env.reset(seed=0)
    t0 = time.perf_counter()
    for a in actions:
        env.step(a)
    return time.perf_counter() - t0


class RawFloor:
    """``mj_step`` + ``Renderer.render()`` on the env's model, replaying the env's controls."""

    def __init__(self, env, actions: np.ndarray, cams: tuple[str, ...], size) -> None:
        scene = env.scene
        self.model = scene.model
        env.reset(seed=0)
        self.start = np.empty(mujoco.mj_stateSize(self.model, FULL))
        mujoco.mj_getState(self.model, scene.data, self.start, FULL)
        self.ctrls = np.empty((len(actions), self.model.nu))
        for i, a in enumerate(actions):  # untimed: the controls the env applies
            env.step(a)
            self.ctrls[i] = scene.data.ctrl
        self.ticks = int(env.task.n_ctrl_steps)
        self.substeps = int(scene.n_substeps)
        self.cams = cams
        self.env_image = scene.render_images()[cams[-1]].copy() if cams else None
        self.image = None
        self.renderer = None
        if cams:  # the shadow map the env's cameras use at this size (set at creation only)
            from trossen_arm_mujoco.sim.cameras import shadow_map_size

            quality = self.model.vis.quality
            own = int(quality.shadowsize)
            self.shadow_map = quality.shadowsize = shadow_map_size(own, *size)
            try:
                self.renderer = mujoco.Renderer(self.model, *size)
            finally:
                quality.shadowsize = own
            self.renderer.update_scene(mujoco.MjData(self.model), camera=cams[0])
            self.renderer.render()  # warm up (first frame)

    def time(self) -> float:
        model, renderer, cams = self.model, self.renderer, self.cams
        data = mujoco.MjData(model)
        mujoco.mj_setState(model, data, self.start, FULL)
        mujoco.mj_forward(model, data)
        ticks, substeps = self.ticks, self.substeps
        image = None
        t0 = time.perf_counter()
        for ctrl in self.ctrls:
            data.ctrl[:] = ctrl
            for _ in range(ticks):
                mujoco.mj_step(model, data, substeps)
            for cam in cams:
                renderer.update_scene(data, camera=cam)
                image = renderer.render()
        wall = time.perf_counter() - t0
        self.image = image
        return wall

    def same_images(self) -> bool | None:
        """Whether the floor's last image equals the env's (the same trajectory and view)."""
        if self.env_image is None or self.image is None:
            return None
        return bool(np.array_equal(self.env_image, self.image))

    def close(self) -> None:
        if self.renderer is not None:
            self.renderer.close()


def _worker(args, barrier, results) -> None:
    """One scaling worker: its own env; per repeat, wait for all, then time the steps."""
    env = make_env(args)
    actions = replay_actions(args.steps)
    try:
        env_time(env, actions[:2])  # warm up (GL context, first render)
        for r in range(args.repeats):
            env.reset(seed=0)
            barrier.wait()
            t0 = time.perf_counter()  # CLOCK_MONOTONIC: comparable across processes
            for a in actions:
                env.step(a)
            results.put((r, t0, time.perf_counter()))
    finally:
        env.close()


def scaling(args, workers: int) -> float:
    """Best total steps/s of ``workers`` processes, each stepping its own env."""
    ctx = multiprocessing.get_context("spawn")
    barrier, results = ctx.Barrier(workers), ctx.Queue()
    procs = [ctx.Process(target=_worker, args=(args, barrier, results)) for _ in range(workers)]
    for p in procs:
        p.start()
    spans: dict[int, list[tuple[float, float]]] = {}
    try:
        for _ in range(workers * args.repeats):
            r, t0, t1 = results.get(timeout=600)
            spans.setdefault(r, []).append((t0, t1))
    finally:
        for p in procs:
            p.join(timeout=60)
    if any(p.exitcode != 0 for p in procs):
        raise SystemExit(f"a worker failed (exit codes {[p.exitcode for p in procs]})")
    best = 0.0
    for r in spans.values():
        wall = max(t1 for _, t1 in r) - min(t0 for t0, _ in r)
        best = max(best, workers * args.steps / wall)
    return best


def policy_rates(args, workers: int) -> tuple[float, float]:
    """(steady, whole-call) episodes/s of ``evaluate`` with ``workers`` local workers."""
    from trossen_arm_mujoco.eval.lerobot_policy import checkpoint_features
    from trossen_arm_mujoco.eval.runner import EvalSettings, evaluate
    from trossen_arm_mujoco.sim.camera_settings import DEFAULT_SIZE, CameraSettings

    found = {} if args.policy == "scripted" else checkpoint_features(args.policy)
    cameras = CameraSettings(found.get("cam_names", ()), found.get("image_size", DEFAULT_SIZE))
    settings = EvalSettings(
        policy=args.policy,
        task=args.task,
        num_episodes=args.episodes,
        cameras=cameras,
        episode_length=args.episode_length,
        layout=found.get("layout", "kit14"),
        output_dir=os.devnull,
        controller_checks=args.controller_checks == "on",
    )
    arrivals: list[float] = []
    t0 = time.perf_counter()
    evaluate(settings, workers, on_episode=lambda _: arrivals.append(time.perf_counter()))
    whole = args.episodes / (time.perf_counter() - t0)
    half = len(arrivals) // 2  # every worker is running by then (the caller from the start)
    steady = (len(arrivals) - 1 - half) / max(arrivals[-1] - arrivals[half], 1e-9)
    return steady, whole


def fresh_rates(args, workers: int) -> tuple[float, float]:
    """``policy_rates`` in a new Python process (nothing imported yet: the whole call pays
    every import, as a ``trossen-mujoco eval`` run does)."""
    argv = [
        sys.executable,
        __file__,
        "--policy",
        args.policy,
        "--task",
        args.task,
        "--episodes",
        str(args.episodes),
        "--episode_length",
        str(args.episode_length),
        "--controller_checks",
        args.controller_checks,
        "--rates_of",
        str(workers),
    ]
    run = subprocess.run(argv, capture_output=True, text=True)
    line = next((x for x in run.stdout.splitlines() if x.startswith("RATES ")), None)
    if run.returncode != 0 or line is None:
        raise SystemExit(f"--fresh: the run of {workers} worker(s) failed: {run.stderr[-2000:]}")
    steady, whole = json.loads(line[len("RATES ") :])
    return steady, whole


def policy_table(args, counts: list[int]) -> None:
    from trossen_arm_mujoco.eval.runner import threads_per_worker
    from trossen_arm_mujoco.processes import available_cpus

    cpus = available_cpus()
    where = "each count in a new process" if args.fresh else "the counts in one process"
    print(
        f"policy throughput: {args.policy}, {args.task}, {args.episodes} episodes of "
        f"{args.episode_length} steps, controller checks {args.controller_checks}, {where}; "
        f"{cpus} usable CPUs, load average {os.getloadavg()[0]:.1f} (other processes "
        "share these cores)"
    )
    print(
        f"  {'workers':>7}  {'threads':>7}  {'episodes/s':>10}  {'(whole)':>8}  "
        f"{'ratio':>6}  {'(whole)':>7}"
    )
    base = None
    for n in counts:
        steady, whole = (fresh_rates if args.fresh else policy_rates)(args, n)
        base = base or (steady, whole)
        print(
            f"  {n:>7}  {threads_per_worker(n, cpus):>7}  {steady:>10.3f}  {whole:>8.3f}  "
            f"{steady / base[0]:>6.2f}  {whole / base[1]:>7.2f}",
            flush=True,
        )


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", default="sim_transfer_cube", help="bimanual task")
    p.add_argument("--cams", default="cam_high", help="observed cameras, comma list or none")
    p.add_argument("--image_size", default="96x128", help="HxW of the observed images")
    p.add_argument("--steps", type=int, default=300, help="env steps per timed run")
    p.add_argument("--repeats", type=int, default=3, help="timed runs of each (best kept)")
    p.add_argument("--workers", default="1,2", help="worker counts of the scaling table")
    p.add_argument(
        "--policy",
        default=None,
        help="time this policy's evaluation instead (checkpoint or 'scripted')",
    )
    p.add_argument("--episodes", type=int, default=8, help="episodes per --policy run")
    p.add_argument("--episode_length", type=int, default=100, help="steps per episode")
    p.add_argument(
        "--controller_checks",
        choices=("on", "off"),
        default="on",
        help="the arm controller's checks in --policy runs (off: an untrained "
        "checkpoint's episodes run to the end)",
    )
    p.add_argument(
        "--fresh", action="store_true", help="run each --policy worker count in a new process"
    )
    p.add_argument("--rates_of", type=int, default=0, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    from trossen_arm_mujoco.eval.env import parse_cameras, parse_image_size

    args.cam_list = parse_cameras(args.cams)
    args.size = parse_image_size(args.image_size)
    counts = [int(n) for n in args.workers.split(",") if n.strip()]
    if args.steps < 1 or args.repeats < 1 or not counts or min(counts) < 1:
        p.error("--steps, --repeats and every --workers count must be at least 1")
    if args.policy is not None:
        if args.episodes < 2 * max(counts) or args.episode_length < 1:
            p.error("--episodes must be at least twice the largest --workers count")
        if args.rates_of:  # one count, for --fresh's parent
            return print("RATES " + json.dumps(policy_rates(args, args.rates_of)), flush=True)
        return policy_table(args, counts)

    actions = replay_actions(args.steps)
    env = make_env(args)
    floor = RawFloor(env, actions, args.cam_list, args.size)
    env_time(env, actions[:2])  # warm up the env's renderer too
    env_wall, raw_wall = np.inf, np.inf
    for _ in range(args.repeats):  # interleaved, so both see the same load
        env_wall = min(env_wall, env_time(env, actions))
        raw_wall = min(raw_wall, floor.time())
    ticks, substeps = floor.ticks, floor.substeps
    same = floor.same_images()
    shadow = f", shadow map {floor.shadow_map}" if args.cam_list else ""
    floor.close()
    env.close()

    cams = ",".join(args.cam_list) or "none"
    h, w = args.size
    print(
        f"eval throughput: {args.task}, cameras {cams} at {h}x{w}, {args.steps} steps, best "
        f"of {args.repeats}; {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}"
    )
    env_rate, raw_rate = args.steps / env_wall, args.steps / raw_wall
    per_step = f"{ticks * substeps} mj_step + {len(args.cam_list)} render(s) per step"
    print(f"  KitPolicyEnv.step     {env_rate:8.1f} steps/s  {1e3 / env_rate:7.2f} ms/step")
    print(
        f"  raw floor             {raw_rate:8.1f} steps/s  {1e3 / raw_rate:7.2f} ms/step"
        f"  ({per_step})"
    )
    print(f"  ratio env/raw         {env_rate / raw_rate:8.2f}")
    if same is not None:
        print(
            f"  (floor renders the env's view{shadow}; last images identical: "
            f"{'yes' if same else 'NO'})"
        )
    print("scaling (spawned worker processes, each its own env):")
    print(f"  {'workers':>7}  {'total steps/s':>13}  {'speedup':>7}  {'efficiency':>10}")
    base = None
    for n in counts:
        rate = scaling(args, n)
        if base is None:  # one worker's rate (per worker of the first count)
            base = rate / n
        speedup = rate / base
        print(f"  {n:>7}  {rate:>13.1f}  {speedup:>7.2f}  {speedup / n:>10.2f}", flush=True)


if __name__ == "__main__":
    main()
