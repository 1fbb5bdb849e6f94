"""Mobile AI: drive to the table, then pick and place with both arms (Trossen's demo).

    python trossen_arm_mujoco/scripts/mobile_ai_pick_place.py              # in the viewer
    python trossen_arm_mujoco/scripts/mobile_ai_pick_place.py --headless   # prints the result

The base drives ``DRIVE`` m toward the table on its wheels (``base_velocity`` commands
through the robot layer: x.vel at most ``DRIVE_SPEED`` m/s, heading held), then stops. With
one vendor-style IK ``Controller`` per arm, the left arm picks the 50 mm cube and puts it
down in the middle of the table, and the right arm picks it there and places it on the
green target. Exit status 0 when the cube rests within ``SUCCESS_DISTANCE`` of the target,
else 1.
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
from trossen_arm_mujoco.scripts.ik_demo import Waypoint, demo_parser, play, show, use_viewer
from trossen_arm_mujoco.src.controller import Controller, RobotType

__all__ = ["DRIVE", "SUCCESS_DISTANCE", "BaseDriver", "cli", "drive", "main", "plan"]

SCENE = "mobile_ai/mobile_ai_scene.xml"
DRIVE = 0.3  # m the base drives forward, toward the table
DRIVE_SPEED = 0.3  # m/s, the most the base is asked for
DRIVE_STEPS = 1000  # physics steps (2 ms) for the drive
HALF = 0.025  # m, half the cube's side
Z = MOBILE_AI_TABLE_TOP + HALF  # the cube's center resting on the table
HANDOVER = np.array([0.85, -0.1, Z])  # m, world: between the arms, off the target
CLEARANCE = 0.1  # m above the cube while carrying
SUCCESS_DISTANCE = 0.02  # m, cube center to target in the table plane


class BaseDriver:
    """Drives the base to ``x`` (m, world) along its heading and holds it there: each
    ``tick`` gives the robot layer's base controller [x.vel, theta.vel] (a proportional
    approach at most ``DRIVE_SPEED``, the heading held at its start)."""

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


def _pick_place(arm: str, pick: np.ndarray, place: np.ndarray, home) -> list[Waypoint]:
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
        Waypoint(350, {arm: home}),
    ]


def plan(cube: np.ndarray, target: np.ndarray, homes: dict) -> list[Waypoint]:
    """The left arm's pick-and-place to the middle and the right arm's to the target, each
    arm back at its ``homes`` position after (2 ms physics steps)."""
    return _pick_place("left", cube, HANDOVER, homes["left"]) + _pick_place(
        "right", HANDOVER, target, homes["right"]
    )


def drive(model, data, driver: BaseDriver, after_step=None) -> bool:
    """``DRIVE_STEPS`` physics steps of the base driving to its goal, the arms holding their
    joints; False when ``after_step`` stopped it."""
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
    arms = {
        side: Controller(
            model, data, RobotType.MOBILE_AI, ee_site_name=f"{side}/ee_site", ik_scale=1.0
        )
        for side in ("left", "right")
    }
    driver = BaseDriver(model, data, goal_x=float(data.qpos[0]) + DRIVE)
    target = data.site("target_site").xpos.copy()
    target[2] = Z
    return model, data, arms, driver, cube, data.qpos[cube : cube + 3].copy(), target


def report(data, cube: int, target: np.ndarray, driver: BaseDriver) -> int:
    """Print what happened; 0 when the cube rests within ``SUCCESS_DISTANCE``, else 1."""
    pos = data.qpos[cube : cube + 3]
    miss = float(np.linalg.norm(pos[:2] - target[:2]))
    if miss <= SUCCESS_DISTANCE and abs(pos[2] - Z) < 0.01:
        print(
            f"drove {driver.travelled:.3f} m to the table; the left arm picked the cube and "
            f"handed it over on the table; the right arm placed it {miss:.3f} m from the target"
        )
        return 0
    print(
        f"drove {driver.travelled:.3f} m; the cube ended at {np.round(pos, 3).tolist()} m, "
        f"{miss:.3f} m from the target {np.round(target, 3).tolist()} (success: within "
        f"{SUCCESS_DISTANCE} m, resting on the table)"
    )
    return 1


def main(argv: Sequence[str] | None = None) -> int:
    """Run the demo; see the module docstring."""
    args = demo_parser(__doc__.splitlines()[0]).parse_args(argv)
    model, data, arms, driver, cube, start, target = setup()

    def run(after_step=None) -> None:
        if drive(model, data, driver, after_step):
            homes = {side: arm.get_ee_pose()[0] for side, arm in arms.items()}
            steps = plan(start, target, homes)
            if play(model, data, arms, steps, after_step, tick=driver.tick):
                result.append(report(data, cube, target, driver))

    result: list[int] = []
    if not use_viewer(args.headless):
        run()
        return result[0]

    def hold():
        driver.tick()
        for arm in arms.values():
            arm.robot.compute_control()

    show(model, data, run, hold, lookat=(0.8, 0.0, 0.8), distance=2.2)
    if not result:
        print("the viewer was closed before the demo finished")
    return result[0] if result else 0


def cli(argv: Sequence[str] | None = None) -> int:
    """Entry point: user errors as one line, exit status 2."""
    return run_cli(main, argv)


if __name__ == "__main__":
    sys.exit(cli())
