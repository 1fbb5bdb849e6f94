"""Stationary AI dual-arm pick-and-place with the vendor's IK ``Controller`` (Trossen's demo).

    python trossen_arm_mujoco/scripts/stationary_ai_pick_place.py              # in the viewer
    python trossen_arm_mujoco/scripts/stationary_ai_pick_place.py --headless   # prints the result

One ``Controller`` per arm. The left arm picks the 25 mm cube on its side of the table and
puts it down in the middle; the right arm picks it there and places it on its side (the
vendor's demo hands the cube over in the air; here the hand-over is on the table). Exit
status 0 when the cube rests within ``SUCCESS_DISTANCE`` of the target, else 1.
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

from trossen_arm_mujoco.assets import STATIONARY_TABLE_TOP, asset_path
from trossen_arm_mujoco.errors import run_cli
from trossen_arm_mujoco.scripts.ik_demo import Waypoint, demo_parser, play, show, use_viewer
from trossen_arm_mujoco.src.controller import Controller, RobotType

__all__ = ["CUBE_START", "HANDOVER", "PLACE_TARGET", "SUCCESS_DISTANCE", "cli", "main", "plan"]

SCENE = "stationary_ai/trossen_ai_scene_joint.xml"
HALF = 0.0125  # m, half the cube's side
Z = STATIONARY_TABLE_TOP + HALF  # the cube's center resting on the table
CUBE_START = np.array([0.05, 0.2, Z])  # m, world
HANDOVER = np.array([0.05, 0.0, Z])
PLACE_TARGET = np.array([0.05, -0.2, Z])
HOMES = {"left": np.array([0.0, 0.25, 0.25]), "right": np.array([0.0, -0.25, 0.25])}
CLEARANCE = 0.1  # m above the cube while carrying
SUCCESS_DISTANCE = 0.02  # m, cube center to target in the table plane


def _pick_place(arm: str, pick: np.ndarray, place: np.ndarray) -> list[Waypoint]:
    up = np.array([0.0, 0.0, CLEARANCE])
    low = np.array([0.0, 0.0, 0.004])
    return [
        Waypoint(450, {arm: pick + up}, grippers={arm: "open"}),
        Waypoint(300, {arm: pick}),
        Waypoint(200, {arm: pick}, grippers={arm: "close"}),
        Waypoint(300, {arm: pick + up}),
        Waypoint(450, {arm: place + up}),
        Waypoint(300, {arm: place + low}),
        Waypoint(150, {arm: place + low}, grippers={arm: "open"}),
        Waypoint(250, {arm: place + up}),
        Waypoint(350, {arm: HOMES[arm]}),
    ]


def plan() -> list[Waypoint]:
    """The left arm's pick-and-place to the middle, then the right arm's to the target
    (2 ms physics steps)."""
    return _pick_place("left", CUBE_START, HANDOVER) + _pick_place("right", HANDOVER, PLACE_TARGET)


def setup() -> tuple[mujoco.MjModel, mujoco.MjData, dict[str, Controller], int]:
    """The kit at home with the cube at ``CUBE_START``; (model, data, arm controllers by
    side, the cube's qpos address)."""
    model = mujoco.MjModel.from_xml_path(str(asset_path(SCENE)))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    cube = model.joint("red_box_joint").qposadr[0]
    data.qpos[cube : cube + 7] = [*CUBE_START, 1, 0, 0, 0]
    mujoco.mj_forward(model, data)
    arms = {
        side: Controller(
            model,
            data,
            RobotType.STATIONARY_AI,
            ee_site_name=f"{side}/ee_site",
            ik_scale=1.0,
            ik_damping=0.03,
        )
        for side in ("left", "right")
    }
    return model, data, arms, cube


def report(data: mujoco.MjData, cube: int) -> int:
    """Print where the cube ended; 0 when placed within ``SUCCESS_DISTANCE``, else 1."""
    pos = data.qpos[cube : cube + 3]
    miss = float(np.linalg.norm(pos[:2] - PLACE_TARGET[:2]))
    if miss <= SUCCESS_DISTANCE and abs(pos[2] - Z) < 0.01:
        print(
            "the left arm picked the cube and handed it over on the table; the right arm "
            f"placed it {miss:.3f} m from the target"
        )
        return 0
    print(
        f"the cube ended at {np.round(pos, 3).tolist()} m, {miss:.3f} m from the target "
        f"{PLACE_TARGET.tolist()} (success: within {SUCCESS_DISTANCE} m, resting on the table)"
    )
    return 1


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; see the module docstring."""
    args = demo_parser(__doc__.splitlines()[0]).parse_args(argv)
    model, data, arms, cube = setup()
    if not use_viewer(args.headless):
        play(model, data, arms, plan())
        return report(data, cube)
    result = []

    def run(after_step):
        if play(model, data, arms, plan(), after_step):
            result.append(report(data, cube))

    def hold():
        for arm in arms.values():
            arm.robot.compute_control()

    show(model, data, run, hold, lookat=(0.0, 0.0, 0.1), distance=1.4)
    if not result:
        print("the viewer was closed before the demo finished")
    return result[0] if result else 0


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: user errors as one line, exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
