"""The loop rate `trossen-mujoco teleop` achieves with each camera setting, against served
leader arms on loopback (no hardware).

    MUJOCO_GL=egl python benchmarks/teleop_rate.py                 # 300-step episodes at 50 Hz
    MUJOCO_GL=egl python benchmarks/teleop_rate.py --episode_len 100 --settings none

Records one state-only scripted transfer, serves it as two leader arms
(``serve --role leader --replay``, 127.0.9.4 and 127.0.9.5, in another process), then runs
``teleop`` once per camera setting and reads each episode's ``achieved_fps``,
``loop_overruns`` and ``tracking_rms_rad`` attributes. Steps are paced to the wall clock, so
each setting takes ``episode_len / fps`` seconds plus start-up; software (EGL/Mesa) rendering
sets the pace with cameras. Prints one line per setting, with the machine's CPU count and
load average.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py

#: Camera settings: name -> the teleop flags.
SETTINGS = {
    "none": ["--cam_names", "none"],
    "48x64": ["--cam_names", "cam_high", "--image_size", "48x64"],
    "48x64-no-shadows": ["--cam_names", "cam_high", "--image_size", "48x64", "--no_shadows"],
    "240x320-no-shadows": ["--cam_names", "cam_high", "--image_size", "240x320", "--no_shadows"],
}
LEADERS = ("127.0.9.4", "127.0.9.5")  # loopback only


def _cli(*args: str) -> list[str]:
    return [sys.executable, "-m", "trossen_arm_mujoco.cli", *args]


def measure(root: Path, episode: Path, name: str, steps: int, fps: int) -> dict[str, float]:
    """Serve the leaders, teleop one episode with setting ``name``, return its attributes."""
    leaders = subprocess.Popen(
        _cli(
            "serve",
            "--role",
            "leader",
            "--replay",
            str(episode),
            "--left_ip",
            LEADERS[0],
            "--right_ip",
            LEADERS[1],
        ),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        subprocess.run(
            _cli(
                "teleop",
                "--leader_left_ip",
                LEADERS[0],
                "--leader_right_ip",
                LEADERS[1],
                "--root_dir",
                str(root),
                "--data_dir",
                f"teleop_{name}",
                "--fps",
                str(fps),
                "--episode_len",
                str(steps),
                *SETTINGS[name],
            ),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            check=True,
            timeout=600,
        )
    finally:
        leaders.terminate()
        leaders.wait(timeout=30)
    with h5py.File(root / f"teleop_{name}" / "episode_0.hdf5", "r") as f:
        return {k: float(f.attrs[k]) for k in ("achieved_fps", "loop_overruns", "tracking_rms_rad")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episode_len", type=int, default=300)
    parser.add_argument("--fps", type=int, default=50)
    parser.add_argument("--settings", default=",".join(SETTINGS), help=f"of {list(SETTINGS)}")
    args = parser.parse_args()
    names = args.settings.split(",")
    unknown = [n for n in names if n not in SETTINGS]
    if unknown:
        parser.error(f"unknown settings {unknown}; valid: {list(SETTINGS)}")
    os.environ.setdefault("MUJOCO_GL", "egl")
    print(
        f"teleop loop rate, {args.episode_len} steps at --fps {args.fps}, {os.cpu_count()} CPUs, "
        f"load average {os.getloadavg()[0]:.1f}, {time.strftime('%Y-%m-%d')}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        subprocess.run(
            _cli(
                "record",
                "--root_dir",
                tmp,
                "--data_dir",
                "leaders",
                "--num_episodes",
                "1",
                "--cam_names",
                "none",
            ),
            stdout=subprocess.DEVNULL,
            check=True,
        )
        for name in names:
            got = measure(
                root, root / "leaders" / "episode_0.hdf5", name, args.episode_len, args.fps
            )
            print(
                f"  {name:20s} {got['achieved_fps']:5.1f} Hz of {args.fps}, "
                f"{got['loop_overruns']:.0f} late steps, tracking RMS "
                f"{got['tracking_rms_rad']:.4f} rad, load average {os.getloadavg()[0]:.1f}"
            )


if __name__ == "__main__":
    main()
