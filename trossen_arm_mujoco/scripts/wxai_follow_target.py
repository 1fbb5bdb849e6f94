"""WidowX AI follows a target cube with the vendor's IK ``Controller`` (Trossen's demo).

    python trossen_arm_mujoco/scripts/wxai_follow_target.py              # in the viewer
    python trossen_arm_mujoco/scripts/wxai_follow_target.py --headless   # prints the result

In the viewer the blue cube is a mocap body: double-click it to select it, then
Ctrl + right-drag moves it (Ctrl + left-drag turns it); the arm's tool frame follows its
position and orientation. Headless, the cube travels a circle of ``RADIUS`` in the y-z plane
for ``PERIODS`` turns; the run prints the tracking error after the first ``SETTLE`` s and
exits 0 when its largest value stays below ``ERROR_BOUND``.

Docs: docs/vendor-api.md.
"""

from __future__ import annotations

if __name__ == "__main__" and not __package__:  # run as a file: import from the repo root
    import sys
    from pathlib import Path

    sys.path[0] = str(
        next(p for p in Path(__file__).resolve().parents if not (p / "__init__.py").is_file())
    )
    import trossen_arm_mujoco  # noqa: F401  (as with -m: the package sets MUJOCO_GL first)

import sys
from collections.abc import Sequence

import mujoco
import numpy as np

from trossen_arm_mujoco.assets import asset_path
from trossen_arm_mujoco.errors import run_cli
from trossen_arm_mujoco.scripts.ik_demo import demo_parser, show, use_viewer
from trossen_arm_mujoco.src.controller import Controller, RobotType

__all__ = ["ERROR_BOUND", "cli", "follow_scene", "main", "track_circle"]

SCENE = "wxai/scene_reach.xml"  # the arm on its table, mocap body "target"
CENTER = np.array([0.3, 0.0, 0.2])  # m, world: the target's start and the circle's center
RADIUS = 0.08  # m
PERIOD = 4.0  # s per turn
PERIODS = 1.5
SETTLE = 0.5  # s before the error counts
ERROR_BOUND = 0.01  # m, largest position error allowed while tracking


def follow_scene() -> tuple[mujoco.MjModel, mujoco.MjData, int]:
    """The reach scene with a draggable 40 mm blue cube on the target mocap body (visual
    only: it collides with nothing); the arm at home. Returns (model, data, mocap id)."""
    spec = mujoco.MjSpec.from_file(str(asset_path(SCENE)))
    body = spec.body("target")
    body.pos = CENTER
    body.add_geom(
        name="target_cube",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.02, 0.02, 0.02],
        rgba=[0.15, 0.35, 0.9, 0.6],
        contype=0,
        conaffinity=0,
    )
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    return model, data, int(model.body("target").mocapid[0])


def track(robot: Controller, data: mujoco.MjData, mocap: int) -> float:
    """One tracking step toward the cube's pose; returns the position error (m)."""
    return robot.set_ee_pose(data.mocap_pos[mocap].copy(), data.mocap_quat[mocap].copy())


def track_circle(model, data, robot: Controller, mocap: int) -> np.ndarray:
    """Move the cube around the circle and track it; the position errors (m) after SETTLE.

    Args:
        model: compiled model.
        data: the state, stepped here.
        robot: the arm's ``Controller``.
        mocap: the target cube's mocap id.
    """
    dt = float(model.opt.timestep)
    steps = int(round(PERIODS * PERIOD / dt))
    errors = []
    for k in range(steps):
        t = k * dt
        phase = 2 * np.pi * t / PERIOD
        data.mocap_pos[mocap] = CENTER + RADIUS * np.array([0.0, np.sin(phase), 1 - np.cos(phase)])
        error = track(robot, data, mocap)
        mujoco.mj_step(model, data)
        if t >= SETTLE:
            errors.append(error)
    return np.asarray(errors)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; see the module docstring."""
    args = demo_parser(__doc__.splitlines()[0]).parse_args(argv)
    model, data, mocap = follow_scene()
    robot = Controller(model, data, RobotType.WXAI, ik_scale=1.0, ik_damping=0.03)
    if use_viewer(args.headless):
        print("double-click the blue cube, then Ctrl + right-drag to move it")
        show(model, data, lambda after_step: None, lambda: track(robot, data, mocap), CENTER)
        return 0
    errors = track_circle(model, data, robot, mocap)
    ok = errors.max() < ERROR_BOUND
    print(
        f"tracked the target around a {RADIUS} m circle for {PERIODS * PERIOD:.1f} s: "
        f"position error mean {errors.mean():.4f} m, max {errors.max():.4f} m "
        f"({'below' if ok else 'above'} the bound {ERROR_BOUND} m)"
    )
    return 0 if ok else 1


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: user errors as one line, exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
