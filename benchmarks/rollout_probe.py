"""LeRobot's own ``lerobot-rollout``, unchanged, with its control loop counted: run in the
Python that has LeRobot (and Trossen's plugin) with ``lerobot-rollout``'s flags.

    $TROSSEN_LEROBOT_PYTHON benchmarks/rollout_probe.py --strategy.type=base --policy.path=... \\
        --robot.type=bi_widowxai_follower_robot ... --duration=12 --fps=30

It wraps the function LeRobot's base strategy calls once a control period
(``send_next_action``) to note the time of each call, runs ``lerobot-rollout``'s ``main``,
and prints one line ``PROBE {"loops": n, "seconds": s, "hz": f, "slowest_ms": m, "exit": c}``
(``benchmarks/plugin_rollout.py`` reads it). Exits with the rollout's status.
"""

from __future__ import annotations

import json
import sys
import time
import traceback


def main() -> int:
    import lerobot.rollout.strategies.base as base
    from lerobot.scripts.lerobot_rollout import main as rollout_main

    import trossen_arm_mujoco.eval.steps  # noqa: F401  (a prepared checkpoint's steps)

    stamps: list[float] = []
    send = base.send_next_action

    def counted(*args, **kwargs):
        stamps.append(time.perf_counter())
        return send(*args, **kwargs)

    base.send_next_action = counted
    code = 0
    try:
        rollout_main()
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:  # reported, then counted as a failed rollout
        traceback.print_exc()
        code = 1
    gaps = [b - a for a, b in zip(stamps, stamps[1:], strict=False)]
    seconds = stamps[-1] - stamps[0] if len(stamps) > 1 else 0.0
    summary = {
        "loops": len(stamps),
        "seconds": round(seconds, 3),
        "hz": round((len(stamps) - 1) / seconds, 2) if seconds > 0 else 0.0,
        "slowest_ms": round(1e3 * max(gaps), 1) if gaps else None,
        "exit": code,
    }
    print("PROBE " + json.dumps(summary), flush=True)
    return code


if __name__ == "__main__":
    sys.exit(main())
