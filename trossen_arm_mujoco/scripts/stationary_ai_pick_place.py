"""Stationary AI dual-arm pick-and-place with the vendor's IK ``Controller`` (Trossen's demo).

    python trossen_arm_mujoco/scripts/stationary_ai_pick_place.py              # in the viewer
    python trossen_arm_mujoco/scripts/stationary_ai_pick_place.py --headless   # prints the result

One ``Controller`` per arm. The left arm picks the 25 mm cube on its side of the table from
above (fingers on the cube's +-y faces) and lifts it to ``HANDOVER``, ``HANDOVER_HEIGHT`` m
above the table. The right arm comes in level from its side, its fingers on the cube's +-x
faces below the left's, and closes: both grippers hold the cube in the air. The left arm
lets go and moves away; the right arm turns its tool down and places the cube on the
target. Exit status 0 when the cube rests within ``SUCCESS_DISTANCE`` of the target, else 1.

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

from trossen_arm_mujoco.assets import STATIONARY_TABLE_TOP, asset_path
from trossen_arm_mujoco.errors import run_cli
from trossen_arm_mujoco.scripts.ik_demo import (
    SUCCESS_DISTANCE,
    Waypoint,
    demo_parser,
    grasp,
    kit_arms,
    play,
    release,
    report_placement,
    run_demo,
)
from trossen_arm_mujoco.src.controller import Controller, RobotType

__all__ = [
    "CUBE_START",
    "HANDOVER",
    "PLACE_TARGET",
    "SUCCESS_DISTANCE",
    "Transfer",
    "cli",
    "handover_plan",
    "main",
    "place_plan",
]

SCENE = "stationary_ai/trossen_ai_scene_joint.xml"
HALF = 0.0125  # m, half the cube's side
Z = STATIONARY_TABLE_TOP + HALF  # the cube's center resting on the table
CUBE_START = np.array([0.05, 0.2, Z])  # m, world
HANDOVER_HEIGHT = 0.14  # m, the cube's center above the table top while both arms hold it
HANDOVER = np.array([0.05, 0.1, STATIONARY_TABLE_TOP + HANDOVER_HEIGHT])
PLACE_TARGET = np.array([0.05, -0.2, Z])
CLEARANCE = 0.1  # m above the cube while carrying
#: The right tool pointing level toward the left arm (+y), fingers closing along world x.
LEVEL = np.array([np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)])
#: Each arm's tool at the home keyframe (m, world), level, pointing at the other arm.
HOMES = {"left": np.array([-0.02, 0.195, 0.271]), "right": np.array([-0.02, -0.195, 0.271])}
HOME_QUATS = {"left": LEVEL * [1.0, 1.0, 1.0, -1.0], "right": LEVEL}
#: The right tool pointing down, fingers still closing along world x.
RIGHT_DOWN = np.array([0.5, -0.5, 0.5, 0.5])
#: The right tool frame relative to the cube's center when it takes the cube (m, world):
#: its fingertips 8 mm past the center, 8 mm below it (clear of the left fingers above).
RIGHT_GRIP = np.array([0.0, 0.008, -0.008])
APPROACH = np.array([0.0, -0.1, 0.0])  # m: where the right tool waits, from its grip


def handover_plan() -> list[Waypoint]:
    """Until both grippers hold the cube in the air (2 ms physics steps): the left arm picks
    it and lifts it to ``HANDOVER`` while the right arm comes level beside it; the right arm
    closes on it."""
    take = HANDOVER + RIGHT_GRIP
    return [
        *grasp("left", CUBE_START, CLEARANCE),
        Waypoint(
            500,
            {"left": HANDOVER, "right": take + APPROACH},
            {"right": LEVEL},
            grippers={"right": "open"},
        ),
        Waypoint(350, {"right": take}),
        Waypoint(200, {"right": take}, grippers={"right": "close"}),
    ]


def place_plan(held: np.ndarray) -> list[Waypoint]:
    """From the transfer on: the left arm opens, rises off the cube and goes home; the right
    arm turns its tool down and places the cube on ``PLACE_TARGET``, then goes home.
    ``held``: the cube's center in the right tool frame (m), as it was taken."""
    down = np.empty(9)
    mujoco.mju_quat2Mat(down, RIGHT_DOWN)
    cube_from_tool = down.reshape(3, 3) @ held  # m, world, the tool turned down
    return [
        Waypoint(150, grippers={"left": "open"}),
        Waypoint(200, {"left": HANDOVER + [0.0, 0.0, 0.025]}),  # up, clear of the cube
        Waypoint(350, {"left": HOMES["left"]}, {"left": HOME_QUATS["left"]}),
        *release("right", PLACE_TARGET - cube_from_tool, CLEARANCE, RIGHT_DOWN),
        Waypoint(350, {"right": HOMES["right"]}, {"right": HOME_QUATS["right"]}),
    ]


class Transfer:
    """The moment the right gripper has closed: the cube's center height above the table
    (m), which arms touch it ("left", "right"), and the cube's center in the right tool
    frame (``held``, m).

    Args:
        model: compiled model.
        data: the state at that moment.
        arms: side -> its ``Controller``.
        cube_geom: the cube's geom id.
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, arms: dict, cube_geom: int):
        cube = data.geom_xpos[cube_geom]
        self.height = float(cube[2] - STATIONARY_TABLE_TOP)
        site = arms["right"].ee_site_id
        self.held = data.site_xmat[site].reshape(3, 3).T @ (cube - data.site_xpos[site])
        self.holders: set[str] = set()
        for contact in data.contact[: data.ncon]:
            pair = {int(contact.geom1), int(contact.geom2)}
            for other in pair - {cube_geom} if cube_geom in pair else ():
                name = model.body(model.geom_bodyid[other]).name
                self.holders.update(s for s in ("left", "right") if name.startswith(f"{s}/"))

    @property
    def in_the_air(self) -> bool:
        """Both grippers hold the cube and it is at least half ``HANDOVER_HEIGHT`` up."""
        return self.holders == {"left", "right"} and self.height > HANDOVER_HEIGHT / 2


def setup() -> tuple[mujoco.MjModel, mujoco.MjData, dict[str, Controller], int]:
    """The kit at home with the cube at ``CUBE_START``; (model, data, arm controllers by
    side, the cube's qpos address)."""
    model = mujoco.MjModel.from_xml_path(str(asset_path(SCENE)))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    cube = model.joint("red_box_joint").qposadr[0]
    data.qpos[cube : cube + 7] = [*CUBE_START, 1, 0, 0, 0]
    mujoco.mj_forward(model, data)
    return model, data, kit_arms(model, data, RobotType.STATIONARY_AI), cube


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; see the module docstring."""
    args = demo_parser(__doc__.splitlines()[0]).parse_args(argv)
    model, data, arms, cube = setup()
    cube_geom = model.geom("red_box").id

    def demo(after_step) -> int | None:
        level = {"right": LEVEL}  # the right arm starts level (its home pose)
        if not play(model, data, arms, handover_plan(), after_step, orientations=level):
            return None
        transfer = Transfer(model, data, arms, cube_geom)
        steps = place_plan(transfer.held)
        if not play(model, data, arms, steps, after_step, orientations=level):
            return None
        if not transfer.in_the_air:
            print(
                f"the hand-over failed: the cube was {transfer.height:.3f} m above the table, "
                f"held by {sorted(transfer.holders) or 'no arm'} (wanted: both arms, above "
                f"{HANDOVER_HEIGHT / 2} m)"
            )
            return 1
        done = (
            "the left arm picked the cube and handed it to the right arm in the air "
            f"({transfer.height:.3f} m above the table); the right arm placed it"
        )
        return report_placement(data.qpos[cube : cube + 3], PLACE_TARGET, done)

    def hold():
        for arm in arms.values():
            arm.robot.compute_control()

    return run_demo(args.headless, model, data, demo, hold, lookat=(0.0, 0.0, 0.1), distance=1.4)


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: user errors as one line, exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
