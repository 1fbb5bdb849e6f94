"""Pixel-observation stepping speed with shadows on and off, against raw MuJoCo.

    MUJOCO_GL=egl python benchmarks/pixel_shadows.py                  # 128x128, 200 steps
    MUJOCO_GL=egl python benchmarks/pixel_shadows.py --size 480x640 --steps 50 --clock cpu

For each gymnasium id (default: WXAIPush-v0 and StationaryAITransferCube-v0) and
``shadows`` in (True, False), it times ``--steps`` steps of ``gym.make(id, obs_type="pixels",
width, height, shadows)`` with uniform random actions (resets included), and the floor: a
bare loop on the same compiled model that runs the same number of ``mujoco.mj_step`` physics
steps per env step and renders the same camera with a ``mujoco.Renderer`` of the same size
and shadow map (``sim.cameras.shadow_map_size``). Rates are env steps per second; ``ratio``
= floor / env (1.0 = no overhead). ``raw, model map`` is the floor with the model's full
shadow map, what a plain ``mujoco.Renderer`` pays. The best of ``--repeats`` interleaved
runs is kept; ``--clock cpu`` times this process's CPU time (render threads included),
steadier than wall time on a busy machine.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}
clock = time.perf_counter  # set by --clock
DEFAULT_IDS = ("TrossenMujoco/WXAIPush-v0", "TrossenMujoco/StationaryAITransferCube-v0")


def env_time(env, actions: np.ndarray) -> float:
    """Seconds for ``len(actions)`` env steps (resets at episode ends included)."""
    env.reset(seed=0)
    t0 = clock()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    return clock() - t0


def floor_time(model, camera: int, n_physics: int, steps: int, size, map_size: int) -> float:
    """Seconds for ``steps`` x (``n_physics`` mj_step + one render of ``camera``)."""
    data = mujoco.MjData(model)
    mujoco.mj_resetData(model, data)
    full = int(model.vis.quality.shadowsize)
    model.vis.quality.shadowsize = map_size
    renderer = mujoco.Renderer(model, *size)
    model.vis.quality.shadowsize = full
    try:
        renderer.update_scene(data, camera)
        renderer.render()
        t0 = clock()
        for _ in range(steps):
            mujoco.mj_step(model, data, n_physics)
            renderer.update_scene(data, camera)
            renderer.render()
        return clock() - t0
    finally:
        renderer.close()


def measure(env_id: str, shadows: bool, steps: int, size, repeats: int) -> dict:
    import gymnasium as gym

    from trossen_arm_mujoco.sim.cameras import shadow_map_size

    h, w = size
    env = gym.make(env_id, obs_type="pixels", height=h, width=w, shadows=shadows)
    try:
        base = env.unwrapped
        model = base.scene.model
        cams = base.scene.cameras
        camera = cams.ids[cams.names[0]]
        n_physics = base.probe.n_ctrl_steps * base.scene.n_substeps
        rng = np.random.default_rng(0)
        actions = rng.uniform(-1, 1, (steps, *env.action_space.shape)).astype(np.float32)
        full = int(model.vis.quality.shadowsize)
        small = shadow_map_size(full, h, w)
        env_t, floor_t, full_t = np.inf, np.inf, np.inf
        for _ in range(repeats):  # interleaved, so all see the same machine load
            env_t = min(env_t, env_time(env, actions))
            floor_t = min(floor_t, floor_time(model, camera, n_physics, steps, size, small))
            if shadows and small != full:
                full_t = min(full_t, floor_time(model, camera, n_physics, steps, size, full))
    finally:
        env.close()
    return {
        "name": f"{env_id.split('/')[-1]} shadows={'on' if shadows else 'off'}",
        "env": steps / env_t,
        "raw": steps / floor_t,
        "raw_full": steps / full_t if np.isfinite(full_t) else None,
        "ratio": env_t and floor_t / env_t,
        "map": small if shadows else 0,
    }


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--ids", default=",".join(DEFAULT_IDS), help="comma-separated gym ids")
    p.add_argument("--size", default="128x128", help="image HEIGHTxWIDTH (default 128x128)")
    p.add_argument("--steps", type=int, default=200, help="env steps per timed run")
    p.add_argument("--repeats", type=int, default=3, help="timed runs per case (best kept)")
    p.add_argument("--clock", choices=sorted(CLOCKS), default="wall", help="what to time")
    args = p.parse_args(argv)
    global clock
    clock = CLOCKS[args.clock]
    size = tuple(int(v) for v in args.size.lower().split("x"))

    import trossen_arm_mujoco  # noqa: F401  (registers the ids)

    rows = []
    for env_id in args.ids.split(","):
        for shadows in (True, False):
            rows.append(measure(env_id, shadows, args.steps, size, args.repeats))
            r = rows[-1]
            print(
                f"{r['name']:<46} env {r['env']:7.1f}  raw {r['raw']:7.1f}  ratio {r['ratio']:.2f}",
                flush=True,
            )
    unit = "steps/s" if args.clock == "wall" else "steps/cpu s"
    print(f"\n{args.size} images, {unit}, best of {args.repeats} x {args.steps} steps")
    head = ("env", "env", "raw", "ratio", "shadow map", "raw, model map")
    print(
        f"| {head[0]:<46} | {head[1]:>7} | {head[2]:>7} | {head[3]:>5} | {head[4]:>10} "
        f"| {head[5]:>14} |"
    )
    print(f"|{'-' * 48}|{'-' * 9}|{'-' * 9}|{'-' * 7}|{'-' * 12}|{'-' * 16}|")
    for r in rows:
        full = f"{r['raw_full']:.1f}" if r["raw_full"] else "-"
        shadow_map = str(r["map"]) if r["map"] else "-"
        print(
            f"| {r['name']:<46} | {r['env']:>7.1f} | {r['raw']:>7.1f} | {r['ratio']:>5.2f} "
            f"| {shadow_map:>10} | {full:>14} |"
        )


if __name__ == "__main__":
    main()
