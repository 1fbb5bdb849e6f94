"""The Mobile AI scene is workable through the robot layer alone: the base drives toward the
table on ``base_velocity`` commands, the left arm picks the cube (IK of ``left_arm``, tool
frame pointing down) and places it on the target, the safety floor at the table top."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from trossen_arm_mujoco.assets import MOBILE_AI_TABLE_TOP
from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.robot import Robot, mobile_ai_config

SCENE = Path(ASSETS_DIR) / "mobile_ai" / "mobile_ai_scene.xml"
TABLE_TOP = MOBILE_AI_TABLE_TOP
#: The tool frame pointing down (its x axis, the fingers' direction, along world -z).
DOWN = np.array([np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0])
OPEN, GRASP = 0.044, 0.015  # finger travel (m): open, closed on the 50 mm cube


def test_drive_pick_and_place():
    model = mujoco.MjModel.from_xml_path(str(SCENE))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    robot = Robot(model, mobile_ai_config(), ctrl_dt=0.02, data=data)
    robot.reset()
    robot.set_safety_floor(TABLE_TOP, 0.005)
    base, arm = robot.view.get_move_group("base"), robot.view.get_move_group("left_arm")
    cube = model.body("cube").id

    def run(seconds: float) -> None:
        for _ in range(round(seconds / 0.02)):
            robot.apply_control()
            mujoco.mj_step(model, data, nstep=10)

    # drive straight to x = 0.35 m (the left arm's base then 0.27 m short of the cube)
    for _ in range(300):
        x, _, yaw = base.get_planar_pose(data)
        robot.update_control({"base": [np.clip(1.5 * (0.35 - x), -0.5, 0.5), -2.0 * yaw]})
        run(0.02)
    robot.update_control({"base": [0.0, 0.0]})
    run(0.5)
    x, y, yaw = base.get_planar_pose(data)
    assert abs(x - 0.35) < 0.005 and abs(y) < 0.005 and abs(yaw) < 0.01
    assert robot.controllers["base"].clipped_commands == 0

    def reach(pos, gripper: float, seconds: float) -> None:
        ik = robot.kinematics.solve_ik(
            "left_arm", np.concatenate([pos, DOWN]), q0={"left_arm": arm.joint_pos}
        )
        assert ik.converged, (pos, ik.residual)
        robot.update_control({"left_arm": ik.qpos["left_arm"], "left_gripper": [gripper]})
        run(seconds)

    start = data.xpos[cube].copy()
    reach(start + [0, 0, 0.12], OPEN, 2.0)
    reach(start + [0, 0, 0.005], OPEN, 1.5)
    reach(start + [0, 0, 0.005], GRASP, 1.0)
    reach(start + [0, 0, 0.15], GRASP, 1.5)
    assert data.xpos[cube][2] > start[2] + 0.1  # lifted with the arm
    target = data.site_xpos[model.site("target_site").id].copy()
    reach(target + [0, 0, 0.15], GRASP, 2.0)
    reach(target + [0, 0, 0.03], GRASP, 1.5)
    reach(target + [0, 0, 0.03], OPEN, 1.0)
    reach(target + [0, 0, 0.15], OPEN, 1.0)
    placed = data.xpos[cube]
    assert np.hypot(*(placed[:2] - target[:2])) < 0.03
    assert abs(placed[2] - (TABLE_TOP + 0.025)) < 0.002  # resting on the table
