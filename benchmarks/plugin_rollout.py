"""A checkpoint run by Trossen's own LeRobot plugin against the served kit, scored by the
kit (docs/rehearsal.md, "Trossen's plugin, end to end").

    TROSSEN_LEROBOT_PYTHON=... MUJOCO_GL=egl python benchmarks/plugin_rollout.py \\
        --policy outputs/.../pretrained_model --episodes 10 --seed 0

``trossen-mujoco serve`` streams ``--cameras`` (default ``cam_high``) at 480x640 and 30 frames
per second, as a real kit's cameras would; for each episode the harness draws the scene of
the in-process ``eval``'s ``reset(seed=S + i)`` (object poses, and with ``--randomize LEVEL``
its randomization), starts it on the kit's control channel, runs ``lerobot-rollout
--robot.type=bi_widowxai_follower_robot`` (LeRobot's entry point, unchanged, in
``TROSSEN_LEROBOT_PYTHON``, through ``benchmarks/rollout_probe.py``, which counts its control
loop) for the episode's length, then ends the episode and reads its score. The checkpoint
is prepared first (``trossen-mujoco prepare``: its image steps turn the streamed whole frames
into the images it was trained on). An episode succeeds when the kit judged it a success at
any frame; a rollout that exits non-zero, or any arm fault the kit reports (the plugin's
shutdown moves included), is counted as a fault beside it. Prints one line per episode and
the success rate with its Wilson 95 % interval, the faults and the loop rate.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

PROBE = Path(__file__).with_name("rollout_probe.py")


def rollout_args(
    policy: Path,
    cams: list[str],
    link,
    duration: float,
    fps: int,
    multiplier: float = 3.0,
    return_to_initial: bool = True,
) -> list[str]:
    """``lerobot-rollout``'s flags for the served kit at ``link``; ``multiplier``: the
    plugin's ``min_time_to_move_multiplier`` (each goal's time is ``multiplier / fps``);
    ``return_to_initial``: LeRobot's ``--return_to_initial_position``."""
    cameras = ", ".join(
        f"{c}: {{type: zmq, server_address: {link.host}, port: {link.camera_port}, "
        f"camera_name: {c}, width: 640, height: 480, fps: {fps}}}"
        for c in cams
    )
    return [
        "--strategy.type=base",
        f"--policy.path={policy}",
        "--policy.device=cpu",
        "--robot.type=bi_widowxai_follower_robot",
        f"--robot.left_arm_ip_address={link.left_ip}",
        f"--robot.right_arm_ip_address={link.right_ip}",
        f"--robot.min_time_to_move_multiplier={multiplier:g}",
        f"--robot.cameras={{{cameras}}}",
        "--task=Transfer the cube",
        f"--duration={duration:g}",
        f"--fps={fps}",
        f"--return_to_initial_position={str(return_to_initial).lower()}",
    ]


def _is_fault(line: str) -> bool:
    """Whether a line serve printed is an arm's fault (``<side> arm (<ip>): <STATE>: ...``;
    its connect, disconnect and clear lines are not)."""
    quiet = ("client connected", "client disconnected", "cleared")
    return " arm (" in line and not any(word in line for word in quiet)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--policy", required=True, help="checkpoint folder (pretrained_model)")
    p.add_argument("--episodes", type=int, default=10)
    p.add_argument("--seed", type=int, default=0, help="episode i is eval's seed S + i")
    p.add_argument("--task", default="sim_transfer_cube")
    p.add_argument("--cameras", default="cam_high", help="comma list of streamed cameras")
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        help="seconds a rollout (default: the task's episode, 12 s)",
    )
    p.add_argument("--fps", type=int, default=30, help="the plugin's loop rate")
    p.add_argument("--randomize", default=None, choices=("nominal", "train", "hard"))
    p.add_argument(
        "--min_time_to_move_multiplier",
        type=float,
        default=3.0,
        help="the plugin's goal time in control periods (its default 3: 0.1 s at 30 fps, "
        "which the driver interpolates linearly and leaves its last velocity behind; above "
        "6 at 30 fps, > 0.2 s, the driver's quintic ends each goal at rest)",
    )
    p.add_argument("--camera_port", type=int, default=5591)
    p.add_argument("--control_port", type=int, default=5592)
    p.add_argument(
        "--no_return_to_initial",
        action="store_true",
        help="lerobot-rollout --return_to_initial_position=false: the arms stay where the "
        "policy left them until the plugin's disconnect moves them (docs/rehearsal.md)",
    )
    args = p.parse_args(argv)
    python = os.environ.get("TROSSEN_LEROBOT_PYTHON", "")
    if not python or not Path(python).is_file():
        sys.exit(
            "error: set TROSSEN_LEROBOT_PYTHON to the Python with LeRobot and Trossen's "
            "plugin (lerobot_robot_trossen)"
        )
    from trossen_arm_mujoco.eval.env import KitPolicyEnv
    from trossen_arm_mujoco.eval.prepare import prepare_checkpoint
    from trossen_arm_mujoco.eval.scores import wilson_interval
    from trossen_arm_mujoco.eval.wire_env import start_fields
    from trossen_arm_mujoco.eval.wire_link import ControlClient, KitLink, start_kit, stop_kit
    from trossen_arm_mujoco.tasks.randomization_levels import level_section

    policy = Path(args.policy).expanduser().resolve()
    prepare_checkpoint(policy)
    cams = [c for c in args.cameras.split(",") if c]
    randomize, section = level_section(args.randomize, args.task)
    scenes = KitPolicyEnv(args.task, render_mode=None, randomize=randomize, randomization=section)
    duration = args.duration or scenes.episode_length / scenes.fps
    link = KitLink(camera_port=args.camera_port, control_port=args.control_port).checked()
    kit = start_kit(link, args.task, tuple(cams), (480, 640), args.fps)
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl"}
    results = []
    try:
        control = ControlClient(link.host, link.control_port)
        for i in range(args.episodes):
            seed = args.seed + i
            scenes.reset(seed=seed)
            control.request("start", seed=seed, **start_fields(scenes))
            before = len(kit.lines)
            began = time.monotonic()
            proc = subprocess.run(
                [
                    python,
                    str(PROBE),
                    *rollout_args(
                        policy,
                        cams,
                        link,
                        duration,
                        args.fps,
                        args.min_time_to_move_multiplier,
                        not args.no_return_to_initial,
                    ),
                ],
                env=env,
                capture_output=True,
                text=True,
                timeout=600,
            )
            end = control.request("end")
            probe = next(
                (
                    json.loads(line[6:])
                    for line in proc.stdout.splitlines()
                    if line.startswith("PROBE ")
                ),
                {"exit": proc.returncode},
            )
            faults = [line.strip() for line in kit.lines[before:] if _is_fault(line)]
            failed = proc.returncode != 0 or bool(faults)
            row = {
                "seed": seed,
                "success": bool(end["success"]),
                "max_reward": end["max_reward"],
                "fault": failed,
                "kit_faults": faults,
                "wall_s": round(time.monotonic() - began, 1),
                **probe,
            }
            if proc.returncode != 0:
                row["stderr"] = proc.stderr.strip().splitlines()[-3:]
            results.append(row)
            print(json.dumps(row), flush=True)
        control.close()
    finally:
        stop_kit(kit)
        scenes.close()
    wins = sum(r["success"] for r in results)
    lo, hi = wilson_interval(wins, len(results))
    rates = [r["hz"] for r in results if r.get("hz")]
    print(
        f"success {wins}/{len(results)} ({100 * wins / max(1, len(results)):.1f} %, 95 % CI "
        f"{lo:.1f}-{hi:.1f}); faults {sum(r['fault'] for r in results)}; loop "
        f"{min(rates, default=0):.1f}-{max(rates, default=0):.1f} Hz "
        f"(asked {args.fps})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
