"""WidowX AI pick-and-place with the vendor's IK ``Controller`` (Trossen's first demo).

    python trossen_arm_mujoco/scripts/wxai_pick_place.py              # in the viewer
    python trossen_arm_mujoco/scripts/wxai_pick_place.py --headless   # prints the result

The arm picks the 40 mm cube at (0.35, -0.15) m on the table and places it on the green
marker at (0.35, 0.15) m, following waypoints with ``Controller.set_ee_pose`` every physics
step. Exit status 0 when the cube rests within ``SUCCESS_DISTANCE`` of the target, else 1.
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
from trossen_arm_mujoco.scripts.ik_demo import Waypoint, demo_parser, play, show, use_viewer
from trossen_arm_mujoco.src.controller import Controller, RobotType

__all__ = ["CUBE_START", "PLACE_TARGET", "SUCCESS_DISTANCE", "cli", "main", "pick_place_plan"]

SCENE = "wxai/scene_pick_place.xml"
CUBE_START = np.array([0.35, -0.15, 0.02])  # m, world (the cube's center; table top z = 0)
PLACE_TARGET = np.array([0.35, 0.15, 0.02])
HOME = np.array([0.25, 0.0, 0.25])
CLEARANCE = 0.12  # m above the cube while carrying
SUCCESS_DISTANCE = 0.02  # m, cube center to target in the table plane


def pick_place_plan(pick: np.ndarray, place: np.ndarray, arm: str = "arm") -> list[Waypoint]:
    """Waypoints (2 ms physics steps) picking a cube at ``pick`` and placing it at ``place``
    (its center, m, world), the tool pointing down."""
    up = np.array([0.0, 0.0, CLEARANCE])
    return [
        Waypoint(500, {arm: pick + up}, grippers={arm: "open"}),
        Waypoint(350, {arm: pick}),
        Waypoint(200, {arm: pick}, grippers={arm: "close"}),
        Waypoint(350, {arm: pick + up}),
        Waypoint(500, {arm: place + up}),
        Waypoint(350, {arm: place + 0.005 * up / CLEARANCE}),
        Waypoint(150, {arm: place + 0.005 * up / CLEARANCE}, grippers={arm: "open"}),
        Waypoint(300, {arm: place + up}),
    ]


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


def report(data: mujoco.MjData, cube: int) -> int:
    """Print where the cube ended; 0 when placed within ``SUCCESS_DISTANCE``, else 1."""
    pos = data.qpos[cube : cube + 3]
    miss = float(np.linalg.norm(pos[:2] - PLACE_TARGET[:2]))
    resting = abs(pos[2] - PLACE_TARGET[2]) < 0.01
    if miss <= SUCCESS_DISTANCE and resting:
        print(f"picked the cube and placed it {miss:.3f} m from the target")
        return 0
    print(
        f"the cube ended at {np.round(pos, 3).tolist()} m, {miss:.3f} m from the target "
        f"{PLACE_TARGET.tolist()} (success: within {SUCCESS_DISTANCE} m, resting on the table)"
    )
    return 1


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; see the module docstring."""
    args = demo_parser(__doc__.splitlines()[0]).parse_args(argv)
    model, data, robot, cube = setup()
    plan = pick_place_plan(CUBE_START, PLACE_TARGET)
    if not use_viewer(args.headless):
        play(model, data, {"arm": robot}, plan)
        return report(data, cube)
    result = []

    def run(after_step):
        if play(model, data, {"arm": robot}, plan, after_step):
            result.append(report(data, cube))

    show(model, data, run, robot.robot.compute_control, lookat=(0.35, 0.0, 0.05))
    if not result:
        print("the viewer was closed before the demo finished")
    return result[0] if result else 0


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: user errors as one line, exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
