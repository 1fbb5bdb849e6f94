"""A short demo of the Stationary AI envs, behind ``python trossen_arm_mujoco/ee_sim_env.py``
(mocap arms, flavour "ee") and ``python trossen_arm_mujoco/sim_env.py`` (joint position
actuators, flavour "joint").

With a display, a live MuJoCo viewer shows both arms following a smooth scripted motion in
real time (close the window or wait ``--seconds``). Without one (or with ``--headless``) a few
steps run and one PNG per camera is written to ``--out_dir``. Offscreen rendering without a
display needs ``MUJOCO_GL=egl`` (or ``osmesa``) in the environment.

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from trossen_arm_mujoco.constants import DT, GRIPPER_OPEN, STATIONARY_CAMERAS
from trossen_arm_mujoco.errors import ArgumentParser, UserError, run_cli
from trossen_arm_mujoco.images import write_png
from trossen_arm_mujoco.viewer import close_viewer, display_problem, launch_viewer

__all__ = [
    "CIRCLE_PERIOD",
    "CIRCLE_RADIUS",
    "FLAVOURS",
    "GRIPPER_PERIOD",
    "HEADLESS_STEPS",
    "IMAGE_SIZE",
    "JOINT_WAVES",
    "RAMP_S",
    "build_parser",
    "demo_main",
    "gripper_opening",
    "run_headless",
    "run_live",
    "scripted_action",
]

FLAVOURS = ("ee", "joint")
HEADLESS_STEPS = 25
IMAGE_SIZE = (480, 640)  # (height, width)

# Scripted motion: periods (s) and amplitudes.
CIRCLE_PERIOD = 4.0
CIRCLE_RADIUS = 0.03  # m
GRIPPER_PERIOD = 3.0
RAMP_S = 1.0  # the motion fades in over this time, so nothing jumps at the start
#: Joint sinusoids around START_ARM_POSE: (amplitude rad, period s) for joint_0..joint_5.
JOINT_WAVES = ((0.35, 5.0), (0.2, 4.0), (0.2, 3.5), (0.4, 3.0), (0.4, 4.5), (0.8, 6.0))


def _task_class(flavour: str) -> type:
    """The cube transfer's dm_control task class in ``flavour``, from the task registry."""
    from trossen_arm_mujoco.tasks.dm_tasks import dm_task_class
    from trossen_arm_mujoco.tasks.registry import DEFAULT_TASK

    return dm_task_class(DEFAULT_TASK, flavour)


# ----------------------------------------------------------------------------- motion
def _ramp(t: float) -> float:
    """Smooth 0 -> 1 over RAMP_S seconds (zero slope at both ends)."""
    s = min(max(t / RAMP_S, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)


def gripper_opening(t: float) -> float:
    """Finger travel (m): starts open, closes and reopens smoothly."""
    return 0.5 * GRIPPER_OPEN * (1.0 + math.cos(2.0 * math.pi * t / GRIPPER_PERIOD))


def scripted_action(
    flavour: str, first_obs: dict, low: np.ndarray, high: np.ndarray
) -> Callable[[float], np.ndarray]:
    """action(t) for the demo: a smooth motion that starts exactly at the initial pose.

    ee: each mocap target circles (radius CIRCLE_RADIUS) in the vertical plane across the
    arm, the two arms in opposite phase; joint: sinusoids around START_ARM_POSE. The
    grippers open and close. Actions are clipped to the env's action bounds.

    Args:
        flavour: ``"ee"`` or ``"joint"``.
        first_obs: the env's first observation (the initial pose).
        low: the action's lower bounds.
        high: the action's upper bounds.

    Returns:
        ``action(t)``, ``t`` in seconds.
    """
    if flavour == "ee":
        start_poses = (
            (np.asarray(first_obs["mocap_pose_left"], dtype=float), 0.0),
            (np.asarray(first_obs["mocap_pose_right"], dtype=float), math.pi),
        )

        def action(t: float) -> np.ndarray:
            w = 2.0 * math.pi * t / CIRCLE_PERIOD
            r = CIRCLE_RADIUS * _ramp(t)
            parts = []
            for pose, phase in start_poses:
                offset = r * np.array([math.sin(w + phase), 0.0, math.cos(w + phase)])
                parts.append(np.concatenate([pose[:3] + offset, pose[3:], [gripper_opening(t)]]))
            return np.clip(np.concatenate(parts), low, high)

        return action

    start = np.asarray(first_obs["qpos"], dtype=float)

    def action(t: float) -> np.ndarray:
        a = start.copy()
        ramp = _ramp(t)
        for offset, phase in ((0, 0.0), (8, math.pi / 2)):
            for j, (amp, period) in enumerate(JOINT_WAVES):
                a[offset + j] += ramp * amp * math.sin(2.0 * math.pi * t / period + phase * j)
            a[offset + 6 : offset + 8] = gripper_opening(t)
        return np.clip(a, low, high)

    return action


# ----------------------------------------------------------------------------- runs
def run_live(flavour: str, seconds: float, seed: int | None) -> None:
    """Live viewer, real-time pace, until ``seconds`` or the window is closed.

    Args:
        flavour: ``"ee"`` or ``"joint"``.
        seconds: how long to run (simulated s).
        seed: the episode seed (None: random).
    """
    from trossen_arm_mujoco.utils import make_sim_env

    env = make_sim_env(_task_class(flavour), cam_list=[], random=seed, time_limit=float("inf"))
    try:
        ts = env.reset()
        spec = env.action_spec()
        action = scripted_action(flavour, ts.observation, spec.minimum, spec.maximum)
        physics = env.physics
        viewer, viewer_threads = launch_viewer(physics.model.ptr, physics.data.ptr)
        try:
            viewer.cam.lookat[:] = (0.0, 0.0, 0.1)
            viewer.cam.distance = 1.7
            viewer.cam.azimuth = 160.0
            viewer.cam.elevation = -30.0
            print(
                f"live viewer running ({flavour}): {seconds:g} s, close the window to stop",
                flush=True,
            )
            start = time.monotonic()
            step = 0
            while viewer.is_running() and step * DT < seconds:
                step += 1
                lock = viewer.lock()
                if lock is None:  # the window was closed just now
                    break
                with lock:
                    env.step(action(step * DT))
                viewer.sync()
                lag = start + step * DT - time.monotonic()
                if lag > 0:
                    time.sleep(lag)
                elif lag < -0.25:  # rendering is slower than real time: do not catch up
                    start -= lag
        finally:
            close_viewer(viewer, viewer_threads)
    finally:
        env.task.close()


def run_headless(flavour: str, seconds: float, seed: int | None, out_dir: Path) -> list[Path]:
    """Step the env briefly and save one PNG per camera; returns the written paths.

    The env renders nothing while it steps (``cam_list=[]``); the cameras are rendered once,
    after the last step.

    Args:
        flavour: ``"ee"`` or ``"joint"``.
        seconds: how long to run (simulated s).
        seed: the episode seed (None: random).
        out_dir: the folder for the PNGs.
    """
    from trossen_arm_mujoco.sim.cameras import CameraSet
    from trossen_arm_mujoco.utils import make_sim_env

    n_steps = max(1, min(HEADLESS_STEPS, round(seconds / DT)))
    env = make_sim_env(_task_class(flavour), cam_list=[], random=seed)
    task = env.task
    cameras = None
    try:
        ts = env.reset()
        spec = env.action_spec()
        action = scripted_action(flavour, ts.observation, spec.minimum, spec.maximum)
        for step in range(1, n_steps + 1):
            env.step(action(step * DT))
        physics = env.physics
        cameras = CameraSet(physics.model.ptr, STATIONARY_CAMERAS, *IMAGE_SIZE)
        images = cameras.render_all(physics.data.ptr)
        out_dir.mkdir(parents=True, exist_ok=True)
        paths = []
        for name in STATIONARY_CAMERAS:
            path = out_dir / f"{flavour}_{name}.png"
            write_png(path, images[name])
            paths.append(path)
        return paths
    finally:
        if cameras is not None:
            cameras.close()
        task.close()


def build_parser(flavour: str) -> argparse.ArgumentParser:
    """The argument parser of the ``flavour`` demo (``"ee"``: ``ee_sim_env.py``,
    ``"joint"``: ``sim_env.py``)."""
    script = "ee_sim_env.py" if flavour == "ee" else "sim_env.py"
    kind = "mocap (end-effector)" if flavour == "ee" else "joint-position"
    parser = ArgumentParser(
        prog=f"python trossen_arm_mujoco/{script}",
        description=f"Demo of the Stationary AI {kind} env: a live viewer when a display is "
        "available, else one PNG per camera.",
    )
    parser.add_argument(
        "--seconds",
        type=float,
        default=10.0,
        help=f"length of the live demo (default 10); headless runs at most {HEADLESS_STEPS} "
        f"steps of {DT} s",
    )
    parser.add_argument(
        "--headless", action="store_true", help="never open a window; write camera PNGs"
    )
    parser.add_argument(
        "--out_dir",
        type=Path,
        default=None,
        help="folder for the PNGs (default: a new folder in the system temp dir)",
    )
    parser.add_argument("--seed", type=int, default=0, help="cube placement seed (default 0)")
    return parser


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _offscreen_backend() -> str:
    """The GL backend MuJoCo picked when it was imported: "egl", "osmesa", "glfw", ..."""
    import mujoco

    return getattr(getattr(mujoco, "GLContext", None), "__module__", "").rpartition(".")[2]


def _needs_egl_child() -> bool:
    """True when offscreen rendering would go through GLFW without a display (Linux).

    MuJoCo reads ``MUJOCO_GL`` once, at import; when it was imported before ``MUJOCO_GL``
    was set, only a fresh process can render with EGL.
    """
    return (
        sys.platform.startswith("linux")
        and not os.environ.get("DISPLAY")
        and _offscreen_backend() == "glfw"
        and os.environ.get("MUJOCO_GL", "").lower() != "glfw"  # the user asked for GLFW
    )


def _rerun_with_egl(flavour: str, argv: Sequence[str] | None) -> int:
    """Run the headless demo in a child process with ``MUJOCO_GL=egl``."""
    args = list(sys.argv[1:] if argv is None else argv)
    repo_root = str(Path(__file__).resolve().parents[1])
    env = dict(os.environ, MUJOCO_GL="egl")
    env["PYTHONPATH"] = os.pathsep.join(p for p in (repo_root, env.get("PYTHONPATH")) if p)
    cmd = [sys.executable, "-m", "trossen_arm_mujoco.demo", flavour, "--headless", *args]
    return subprocess.run(cmd, env=env, check=False).returncode


def _main(flavour: str, argv: Sequence[str] | None) -> int:
    if flavour not in FLAVOURS:
        raise UserError(f"unknown demo flavour '{flavour}'; valid: {', '.join(FLAVOURS)}")
    args = build_parser(flavour).parse_args(argv)
    if not math.isfinite(args.seconds) or args.seconds <= 0:
        raise UserError(f"--seconds must be a positive number, got {args.seconds}")
    if not args.headless:
        problem = display_problem()
        if problem is None:
            try:
                run_live(flavour, args.seconds, args.seed)
                return 0
            except UserError:
                raise
            except Exception as exc:
                problem = f"live viewer failed: {_first_line(exc)}"
        print(f"note: {problem}; running headless and writing camera images instead", flush=True)
    if _needs_egl_child():
        return _rerun_with_egl(flavour, argv)
    out_dir = args.out_dir or Path(tempfile.mkdtemp(prefix=f"trossen_demo_{flavour}_"))
    try:
        paths = run_headless(flavour, args.seconds, args.seed, out_dir)
    except UserError:
        raise
    except Exception as exc:
        hint = " (without a display, set MUJOCO_GL=egl)" if _offscreen_backend() == "glfw" else ""
        raise UserError(f"offscreen rendering failed: {_first_line(exc)}{hint}") from exc
    for path in paths:
        print(path)
    return 0


def demo_main(flavour: str, argv: Sequence[str] | None = None) -> int:
    """Run the demo; ``flavour`` is "ee" (mocap arms) or "joint" (joint actuators).

    Returns the exit status: 0 on success, 2 for a user error (printed on one line).
    """
    return run_cli(lambda a: _main(flavour, a), argv)


if __name__ == "__main__":
    flavour_arg = sys.argv[1] if len(sys.argv) > 1 else "ee"
    raise SystemExit(demo_main(flavour_arg, sys.argv[2:]))
