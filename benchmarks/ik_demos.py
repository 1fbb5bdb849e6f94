"""The four IK demo scripts (the vendor's paths, ``docs/vendor-api.md``), each run headless:
its last line (what it did, with the measured distance or tracking error) and its wall time.

    MUJOCO_GL=egl python benchmarks/ik_demos.py

Each script runs in its own process, as a user runs it (``python -m
trossen_arm_mujoco.scripts.<name> --headless``); a script that fails is reported with its
exit status, and the run exits non-zero.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

SCRIPTS = (
    "wxai_pick_place",
    "stationary_ai_pick_place",
    "mobile_ai_pick_place",
    "wxai_follow_target",
)


def main() -> int:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    failed = 0
    print("| script | result | wall s |")
    print("|---|---|---|")
    for name in SCRIPTS:
        start = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", f"trossen_arm_mujoco.scripts.{name}", "--headless"],
            capture_output=True,
            text=True,
            env=env,
        )
        took = time.perf_counter() - start
        lines = (proc.stdout.strip() or proc.stderr.strip() or "(no output)").splitlines()
        result = lines[-1] if proc.returncode == 0 else f"exit {proc.returncode}: {lines[-1]}"
        failed += proc.returncode != 0
        print(f"| {name} | {result} | {took:.1f} |", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
