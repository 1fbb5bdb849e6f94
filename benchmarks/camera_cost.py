"""What cameras cost a recording, and how fast the served kit streams one (docs/benchmarks.md,
"Rendering cost").

    MUJOCO_GL=egl python benchmarks/camera_cost.py                 # both parts
    MUJOCO_GL=egl python benchmarks/camera_cost.py --part record --episodes 2

``record``: ``trossen-mujoco record`` of the same noisy transfer episodes (``--seed 11``), one
run after another in this run, each in a fresh folder: state only, ``cam_high`` at 60x80
with the camera recipes' crop (with shadows, ``--no_antialias``, ``--no_shadows``), then 60
steps with the README's 4 cameras at 480x640 against 60 state-only steps. CPU is the child
processes' user + system time (every thread and worker), the least of ``--repeats`` runs (the
machine's other load only adds); the ratio is against the state-only run of the same length.

``stream``: ``trossen-mujoco serve --cameras cam_high --image_size 480x640`` on loopback for
``--seconds``, then with ``--no_antialias``, each stopped with Ctrl-C (SIGINT); its own last
lines give the frames it published per second (30 asked) and the physics' real-time factor
beside it.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CROP = "cam_high:217,243,150,200"
CLI = [sys.executable, "-m", "trossen_arm_mujoco.cli"]


def children_cpu() -> float:
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def record(folder: str, flags: list[str], env: dict) -> float | None:
    """CPU seconds of one ``record`` run into ``folder`` (None: this version lacks a flag).
    Exit status 1 (episodes kept as failed: the 60-step runs end before the task) counts."""
    before = children_cpu()
    done = subprocess.run(
        CLI + ["record", "--data_dir", folder, *flags],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if "unrecognized arguments" in done.stderr:
        return None
    if done.returncode not in (0, 1) or not list(Path(folder).glob("episode_*.hdf5")):
        sys.exit(f"error: record {' '.join(flags)} failed: {done.stderr.strip()[-400:]}")
    return children_cpu() - before


def record_part(episodes: int, repeats: int, env: dict) -> None:
    common = [
        "--task_name",
        "sim_transfer_cube",
        "--inject_noise",
        "--seed",
        "11",
        "--num_episodes",
        str(episodes),
    ]
    cam = ["--cam_names", "cam_high", "--image_size", "60x80", "--crop", CROP]
    runs = [
        ("state only", common + ["--cam_names", "none"], None),
        ("cam_high 60x80, crop", common + cam, "state only"),
        ("  --no_antialias", common + cam + ["--no_antialias"], "state only"),
        ("  --no_shadows", common + cam + ["--no_shadows"], "state only"),
        ("state only, 60 steps", common + ["--cam_names", "none", "--episode_len", "60"], None),
        ("4 cams 480x640, 60 steps", common + ["--episode_len", "60"], "state only, 60 steps"),
        (
            "  --no_antialias",
            common + ["--episode_len", "60", "--no_antialias"],
            "state only, 60 steps",
        ),
    ]
    cpu: dict[str, float] = {}
    print(f"record: {episodes} noisy transfer episode(s), seed 11, least of {repeats} runs")
    with tempfile.TemporaryDirectory() as tmp:
        for k, (name, flags, against) in enumerate(runs):
            tries = [record(os.path.join(tmp, f"run{k}_{r}"), flags, env) for r in range(repeats)]
            seconds = None if None in tries else min(tries)
            if seconds is None:
                print(f"  {name:<26} (a flag this version lacks)")
                continue
            cpu[name if not name.startswith(" ") else f"{name}{k}"] = seconds
            ratio = f"{seconds / cpu[against]:5.2f}x {against}" if against else ""
            print(f"  {name:<26} CPU {seconds:7.1f} s  {ratio}", flush=True)


def stream_part(seconds: float, env: dict, flags: list[str]) -> None:
    cmd = CLI + ["serve", "--left_ip", "127.0.0.2", "--right_ip", "127.0.0.3", *flags]
    cmd += ["--cameras", "cam_high", "--image_size", "480x640", "--camera_port", "5591"]
    proc = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    time.sleep(seconds)
    proc.send_signal(signal.SIGINT)
    try:
        out, _ = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, _ = proc.communicate()
    rate = re.search(r"cameras: (\d+) frames at ([\d.]+) per s", out)
    rtf = re.search(r"real-time factor ([\d.]+)", out)
    if not rate or not rtf:
        sys.exit(f"error: serve did not report its rates:\n{out[-800:]}")
    shown = " ".join(flags) or "defaults"
    print(
        f"stream: cam_high 480x640, {shown}, {seconds:g} s: {rate.group(2)} frames per s "
        f"(30 asked), physics real-time factor {rtf.group(1)}"
    )


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--part", choices=("all", "record", "stream"), default="all")
    p.add_argument("--episodes", type=int, default=2, help="episodes a record run")
    p.add_argument("--repeats", type=int, default=3, help="record runs of each kind (least kept)")
    p.add_argument("--seconds", type=float, default=30.0, help="how long the stream runs")
    args = p.parse_args(argv)
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    if args.part in ("all", "record"):
        record_part(args.episodes, max(1, args.repeats), env)
    if args.part in ("all", "stream"):
        for flags in ([], ["--no_antialias"]):
            stream_part(args.seconds, env, flags)


if __name__ == "__main__":
    main()
