"""WidowX AI pick-and-place with the vendor's IK ``Controller`` (Trossen's first demo).

    python trossen_arm_mujoco/scripts/wxai_pick_place.py              # in the viewer
    python trossen_arm_mujoco/scripts/wxai_pick_place.py --headless   # prints the result

The arm picks the 40 mm cube at (0.35, -0.15) m on the table and places it on the green
marker at (0.35, 0.15) m, following waypoints with ``Controller.set_ee_pose`` every physics
step. Exit status 0 when the cube rests within ``SUCCESS_DISTANCE`` of the target, else 1.

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
from trossen_arm_mujoco.scripts.ik_demo import (
    SUCCESS_DISTANCE,
    Waypoint,
    demo_parser,
    grasp,
    play,
    release,
    report_placement,
    run_demo,
)
from trossen_arm_mujoco.src.controller import Controller, RobotType

__all__ = ["CUBE_START", "PLACE_TARGET", "SUCCESS_DISTANCE", "cli", "main", "pick_place_plan"]

SCENE = "wxai/scene_pick_place.xml"
CUBE_START = np.array([0.35, -0.15, 0.02])  # m, world (the cube's center; table top z = 0)
PLACE_TARGET = np.array([0.35, 0.15, 0.02])
CLEARANCE = 0.12  # m above the cube while carrying


def pick_place_plan(pick: np.ndarray, place: np.ndarray, arm: str = "arm") -> list[Waypoint]:
    """Waypoints (2 ms physics steps) picking a cube and placing it, the tool pointing down.

    Args:
        pick: (3,) the cube's center where it is (m, world).
        place: (3,) its center where it goes (m, world).
        arm: the arm's name in the waypoints.
    """
    return grasp(arm, pick, CLEARANCE) + release(arm, place, CLEARANCE)


def setup() -> tuple[mujoco.MjModel, mujoco.MjData, Controller, int]:
    """The scene at home, the cube at ``CUBE_START``, the marker at ``PLACE_TARGET``;
    returns (model, data, controller, the cube's qpos address)."""
    model = mujoco.MjModel.from_xml_path(str(asset_path(SCENE)))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    cube = model.joint("cube_joint").qposadr[0]
    data.qpos[cube : cube + 7] = [*CUBE_START, 1, 0, 0, 0]
    data.mocap_pos[model.body("goal").mocapid[0]] = PLACE_TARGET
    mujoco.mj_forward(model, data)
    robot = Controller(model, data, RobotType.WXAI, ik_scale=1.0, ik_damping=0.03)
    return model, data, robot, cube


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; see the module docstring."""
    args = demo_parser(__doc__.splitlines()[0]).parse_args(argv)
    model, data, robot, cube = setup()

    def demo(after_step) -> int | None:
        if not play(
            model, data, {"arm": robot}, pick_place_plan(CUBE_START, PLACE_TARGET), after_step
        ):
            return None
        done = "picked the cube and placed it"
        return report_placement(data.qpos[cube : cube + 3], PLACE_TARGET, done)

    hold = robot.robot.compute_control
    return run_demo(args.headless, model, data, demo, hold, lookat=(0.35, 0.0, 0.05))


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: user errors as one line, exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
