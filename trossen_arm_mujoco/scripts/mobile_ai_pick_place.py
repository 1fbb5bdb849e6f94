"""Mobile AI: drive to the table, then pick and place with both arms (Trossen's demo).

    python trossen_arm_mujoco/scripts/mobile_ai_pick_place.py              # in the viewer
    python trossen_arm_mujoco/scripts/mobile_ai_pick_place.py --headless   # prints the result

The base drives ``DRIVE`` m toward the table on its wheels (``base_velocity`` commands
through the robot layer: x.vel at most ``DRIVE_SPEED`` m/s, heading held), then stops. With
one vendor-style IK ``Controller`` per arm, the left arm picks the 50 mm cube and puts it
down in the middle of the table, and the right arm picks it there and places it on the
green target. Exit status 0 when the cube rests within ``SUCCESS_DISTANCE`` of the target,
else 1.

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
from dataclasses import replace

import mujoco
import numpy as np

from trossen_arm_mujoco.assets import MOBILE_AI_TABLE_TOP, asset_path
from trossen_arm_mujoco.errors import run_cli
from trossen_arm_mujoco.robot.configs import mobile_ai_config
from trossen_arm_mujoco.robot.robot import Robot
from trossen_arm_mujoco.scripts.ik_demo import (
    BRISK,
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
from trossen_arm_mujoco.src.controller import RobotType

__all__ = ["DRIVE", "SUCCESS_DISTANCE", "BaseDriver", "cli", "drive", "main", "plan"]

SCENE = "mobile_ai/mobile_ai_scene.xml"
DRIVE = 0.3  # m the base drives forward, toward the table
DRIVE_SPEED = 0.3  # m/s, the most the base is asked for
DRIVE_STEPS = 1000  # physics steps (2 ms) for the drive
HALF = 0.025  # m, half the cube's side
Z = MOBILE_AI_TABLE_TOP + HALF  # the cube's center resting on the table
HANDOVER = np.array([0.85, -0.1, Z])  # m, world: between the arms, off the target
CLEARANCE = 0.1  # m above the cube while carrying


class BaseDriver:
    """Drives the base to ``x`` (m, world) along its heading and holds it there: each
    ``tick`` gives the robot layer's base controller [x.vel, theta.vel] (a proportional
    approach at most ``DRIVE_SPEED``, the heading held at its start).

    Args:
        model: the Mobile AI scene's compiled model.
        data: its state.
        goal_x: where the base stops (m, world x).
    """

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, goal_x: float):
        full = mobile_ai_config()
        config = replace(
            full,
            groups={"base": full.groups["base"]},
            init_qpos={},
            command_mode={"base": "base_velocity"},
        )
        self.robot = Robot(model, config, data=data)
        self.base = self.robot.view.get_move_group("base")
        self.data = data
        self.goal_x = goal_x
        self.start = self.base.get_planar_pose(data).copy()  # [x, y, yaw]

    def tick(self) -> None:
        """One control tick: the base's velocity command applied (wheel speeds)."""
        x, _, yaw = self.base.get_planar_pose(self.data)
        x_vel = float(np.clip(2.0 * (self.goal_x - x), -DRIVE_SPEED, DRIVE_SPEED))
        theta_vel = float(np.clip(-2.0 * (yaw - self.start[2]), -0.5, 0.5))
        self.robot.update_control({"base": np.array([x_vel, theta_vel])})
        self.robot.compute_control(self.data)

    @property
    def travelled(self) -> float:
        """Distance (m) from the start, in the floor plane."""
        return float(np.linalg.norm(self.base.get_planar_pose(self.data)[:2] - self.start[:2]))


def plan(cube: np.ndarray, target: np.ndarray, homes: dict) -> list[Waypoint]:
    """The left arm's pick-and-place to the middle and the right arm's to the target, each
    arm back at its ``homes`` position after (2 ms physics steps).

    Args:
        cube: (3,) the cube's center (m, world).
        target: (3,) the place target (m, world).
        homes: arm name -> its tool frame's home position (m, world).
    """
    pick, put = BRISK["grasp"], BRISK["release"]
    return [
        *grasp("left", cube, CLEARANCE, steps=pick),
        *release("left", HANDOVER, CLEARANCE, steps=put),
        Waypoint(350, {"left": homes["left"]}),
        *grasp("right", HANDOVER, CLEARANCE, steps=pick),
        *release("right", target, CLEARANCE, steps=put),
        Waypoint(350, {"right": homes["right"]}),
    ]


def drive(model, data, driver: BaseDriver, after_step=None) -> bool:
    """``DRIVE_STEPS`` physics steps of the base driving to its goal, the arms holding their
    joints; False when ``after_step`` stopped it.

    Args:
        model: compiled model.
        data: the state, stepped here.
        driver: the base's driver.
        after_step: called after each step (the viewer's sync); False stops.
    """
    for _ in range(DRIVE_STEPS):
        driver.tick()
        mujoco.mj_step(model, data)
        if after_step is not None and not after_step():
            return False
    return True


def setup():
    """The robot at home; (model, data, arms by side, base driver, cube qpos address,
    cube start, target), positions in m, world."""
    model = mujoco.MjModel.from_xml_path(str(asset_path(SCENE)))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    cube = int(model.joint("cube_joint").qposadr[0])
    arms = kit_arms(model, data, RobotType.MOBILE_AI)
    driver = BaseDriver(model, data, goal_x=float(data.qpos[0]) + DRIVE)
    target = data.site("target_site").xpos.copy()
    target[2] = Z
    return model, data, arms, driver, cube, data.qpos[cube : cube + 3].copy(), target


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; see the module docstring."""
    args = demo_parser(__doc__.splitlines()[0]).parse_args(argv)
    model, data, arms, driver, cube, start, target = setup()

    def demo(after_step) -> int | None:
        if not drive(model, data, driver, after_step):
            return None
        homes = {side: arm.get_ee_pose()[0] for side, arm in arms.items()}
        steps = plan(start, target, homes)
        if not play(model, data, arms, steps, after_step, tick=driver.tick):
            return None
        done = (
            f"drove {driver.travelled:.3f} m to the table; the left arm picked the cube and "
            "handed it over on the table; the right arm placed it"
        )
        pos = data.qpos[cube : cube + 3]
        return report_placement(pos, target, done, prefix=f"drove {driver.travelled:.3f} m; ")

    def hold():
        driver.tick()
        for arm in arms.values():
            arm.robot.compute_control()

    return run_demo(args.headless, model, data, demo, hold, lookat=(0.8, 0.0, 0.8), distance=2.2)


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: user errors as one line, exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
