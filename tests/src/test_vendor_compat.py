"""The vendor's Controller as the vendor's (issue 48, item 4): its scene names load this
project's models, its README example runs unchanged, its public attributes mean what its own
controller's do (docs/vendor-api.md)."""

from __future__ import annotations

import os
from pathlib import Path

import mujoco
import numpy as np
import pytest

import trossen_arm_mujoco
from trossen_arm_mujoco.assets import ASSETS_DIR, asset_path, model_files
from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.src import controller as vendor_api
from trossen_arm_mujoco.src.controller import Controller, RobotType

#: The vendor's scene files (its README's asset tree, which its scripts and its ee_sim_env /
#: sim_env load), under trossen_arm_mujoco/assets -> the scene of this project each includes.
VENDOR_SCENES = {
    "wxai/scene_wxai_pick_place.xml": "wxai/scene_pick_place.xml",
    "wxai/scene_wxai_follow_target.xml": "wxai/scene_reach.xml",
    "stationary_ai/scene.xml": "stationary_ai/trossen_ai_scene_joint.xml",
    "stationary_ai/scene_joint.xml": "stationary_ai/trossen_ai_scene_joint.xml",
    "stationary_ai/scene_mocap.xml": "stationary_ai/trossen_ai_scene.xml",
    "stationary_ai/scene_stationary_ai_pick_place.xml": "stationary_ai/trossen_ai_scene_joint.xml",
    "mobile_ai/scene.xml": "mobile_ai/mobile_ai.xml",
    "mobile_ai/scene_mobile_ai_pick_place.xml": "mobile_ai/mobile_ai_scene.xml",
}
#: The folder the vendor's scripts run from: their scene paths start "trossen_arm_mujoco/".
PACKAGE_PARENT = Path(trossen_arm_mujoco.__file__).resolve().parents[1]


def _mjb(model: mujoco.MjModel) -> bytes:
    """The compiled model as MuJoCo saves it (every array and name)."""
    buf = np.zeros(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buf)
    return buf.tobytes()


def _load(relative: str) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(asset_path(relative)))


# -- (a) the vendor's scene names ------------------------------------------------------------
@pytest.mark.parametrize(("vendor", "ours"), VENDOR_SCENES.items(), ids=list(VENDOR_SCENES))
def test_a_vendor_scene_path_loads_our_model_bit_for_bit(vendor, ours, monkeypatch):
    expected = _mjb(_load(ours))
    monkeypatch.chdir(PACKAGE_PARENT)  # as the vendor's scripts load their scenes
    model = mujoco.MjModel.from_xml_path(f"trossen_arm_mujoco/assets/{vendor}")
    assert _mjb(model) == expected
    # the vendor's constants.ASSETS_DIR + its name, as its utils.make_sim_env joins them
    joined = mujoco.MjModel.from_xml_path(os.path.join(ASSETS_DIR, vendor))
    assert _mjb(joined) == expected
    assert _mjb(_load(vendor)) == expected


def test_the_vendors_basic_wxai_scene_is_our_arm_on_its_table():
    scene, arm, table = (
        _load(p) for p in ("wxai/scene.xml", "wxai/wxai_follower.xml", "wxai/table_scene.xml")
    )
    for size in ("nq", "nv", "nu", "njnt", "nkey", "neq"):
        assert getattr(scene, size) == getattr(arm, size), size
    for size in ("ngeom", "nsite", "ncam", "nlight"):
        assert getattr(scene, size) == getattr(arm, size) + getattr(table, size), size
    assert scene.nbody == arm.nbody + table.nbody - 1  # the arm's bodies first, then the table
    for field in ("body_pos", "body_quat", "body_mass", "body_inertia"):
        np.testing.assert_array_equal(
            getattr(scene, field)[: arm.nbody], getattr(arm, field), err_msg=field
        )
    for field in (
        "jnt_range",
        "dof_armature",
        "actuator_gainprm",
        "actuator_biasprm",
        "actuator_ctrlrange",
        "key_qpos",
    ):
        np.testing.assert_array_equal(getattr(scene, field), getattr(arm, field), err_msg=field)
    assert scene.geom("floor").id >= 0 and scene.geom("table").id >= 0
    assert scene.site("ee_site").id >= 0 and scene.camera("cam").id >= 0


def test_every_scene_file_of_the_vendors_readme_is_shipped():
    assert set(VENDOR_SCENES) | {"wxai/scene.xml"} <= set(model_files())


@pytest.mark.parametrize(
    ("task", "scene", "nmocap", "nu"),
    [
        ("TransferCubeEETask", "scene_mocap.xml", 2, 2),
        ("TransferCubeTask", "scene_joint.xml", 0, 14),
    ],
)
def test_the_vendors_make_sim_env_takes_its_scene_names(task, scene, nmocap, nu):
    """The vendor's ``utils.make_sim_env(task_class, "stationary_ai/scene_*.xml")``."""
    from trossen_arm_mujoco import ee_sim_env, sim_env
    from trossen_arm_mujoco.utils import make_sim_env

    task_class = getattr(ee_sim_env if "EE" in task else sim_env, task)
    env = make_sim_env(task_class, f"stationary_ai/{scene}", cam_list=[], random=0)
    try:
        assert (env.physics.model.nmocap, env.physics.model.nu) == (nmocap, nu)
        assert env.reset().first()
    finally:
        env.task.close()


def test_an_unknown_scene_is_one_line_listing_the_valid_ones():
    from trossen_arm_mujoco.sim_env import TransferCubeTask
    from trossen_arm_mujoco.utils import make_sim_env

    for call in (
        lambda: asset_path("stationary_ai/scene_jiont.xml"),
        lambda: make_sim_env(TransferCubeTask, "stationary_ai/scene_jiont.xml", cam_list=[]),
    ):
        with pytest.raises(UserError) as info:
            call()
        message = str(info.value)
        assert "\n" not in message
        assert message.startswith("unknown scene 'stationary_ai/scene_jiont.xml'; valid scenes: ")
        assert all(name in message for name in VENDOR_SCENES)


# -- (b) the vendor's README example ---------------------------------------------------------
#: The vendor README's "Controller API / Basic Usage" example, word for word but for its
#: arm_joint_names (the README has ["joint_1", "joint_2", ...]; the arm's joints are joint_0
#: to joint_5, as the vendor's own scripts pass). The README leaves mujoco_model and
#: mujoco_data to the reader, and np imported.
README_SETUP = """
from trossen_arm_mujoco.src.controller import Controller, RobotType

# Initialize controller
robot = Controller(
    model=mujoco_model,
    data=mujoco_data,
    robot_type=RobotType.WXAI,  # or RobotType.STATIONARY_AI, RobotType.MOBILE_AI
    arm_joint_names=["joint_0", "joint_1", "joint_2", "joint_3", "joint_4", "joint_5"],
    gripper_joint_names=["left_carriage_joint"],
    ik_scale=1.0,
    ik_damping=0.03,
)
"""
README_COMMANDS = """
# Command end-effector pose
error = robot.set_ee_pose(
    target_position=np.array([0.3, 0.0, 0.2]),
    target_orientation=np.array([1.0, 0.0, 0.0, 0.0]),  # [w, x, y, z]
    position_only=False,
)

# Gripper control
robot.open_gripper()
robot.close_gripper()
"""


def test_the_vendors_readme_example_runs_unchanged(monkeypatch):
    """On the vendor's pick-and-place scene, loaded by its path as its scripts do, from rest
    (all joints 0): the README's commands once per physics step, 600 steps (1.2 s)."""
    monkeypatch.chdir(PACKAGE_PARENT)
    mujoco_model = mujoco.MjModel.from_xml_path(
        "trossen_arm_mujoco/assets/wxai/scene_wxai_pick_place.xml"
    )
    mujoco_data = mujoco.MjData(mujoco_model)
    names = {"mujoco_model": mujoco_model, "mujoco_data": mujoco_data, "np": np}
    exec(compile(README_SETUP, "vendor README", "exec"), names)
    commands = compile(README_COMMANDS, "vendor README", "exec")
    errors = []
    for _ in range(600):
        exec(commands, names)
        errors.append(names["error"])
        mujoco.mj_step(mujoco_model, mujoco_data)
    robot = names["robot"]
    assert isinstance(robot, Controller)
    assert errors[0] > 0.3 and errors[-1] < 1e-3
    position, quat = robot.get_ee_pose()
    np.testing.assert_allclose(position, [0.3, 0.0, 0.2], atol=1e-3)
    assert abs(quat @ [1.0, 0.0, 0.0, 0.0]) > 1 - 1e-4
    assert robot.get_gripper_position() < 0.002  # close_gripper was the last command


# the vendor's four demo scripts' controllers: scene path, robot type, ee site, joint names
_LEFT, _RIGHT = "follower_left_", "follower_right_"
VENDOR_DEMOS = {
    "wxai_pick_place": ("wxai/scene_wxai_pick_place.xml", RobotType.WXAI, "ee_site", ""),
    "wxai_follow_target": ("wxai/scene_wxai_follow_target.xml", RobotType.WXAI, "ee_site", ""),
    "stationary_ai_pick_place left": (
        "stationary_ai/scene_stationary_ai_pick_place.xml",
        RobotType.STATIONARY_AI,
        "follower_left_ee_site",
        _LEFT,
    ),
    "stationary_ai_pick_place right": (
        "stationary_ai/scene_stationary_ai_pick_place.xml",
        RobotType.STATIONARY_AI,
        "follower_right_ee_site",
        _RIGHT,
    ),
    "mobile_ai_pick_place left": (
        "mobile_ai/scene_mobile_ai_pick_place.xml",
        RobotType.MOBILE_AI,
        "follower_left_ee_site",
        _LEFT,
    ),
}


@pytest.mark.parametrize(
    ("scene", "robot_type", "site", "prefix"), VENDOR_DEMOS.values(), ids=list(VENDOR_DEMOS)
)
def test_the_vendors_demo_controllers_on_its_scene_paths(
    scene, robot_type, site, prefix, monkeypatch
):
    """Each controller the vendor's demo scripts build, as they build it, moves its tool 5 cm
    in 400 physics steps."""
    monkeypatch.chdir(PACKAGE_PARENT)
    model = mujoco.MjModel.from_xml_path(f"trossen_arm_mujoco/assets/{scene}")
    data = mujoco.MjData(model)
    key = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    mujoco.mj_resetDataKeyframe(model, data, key)
    mujoco.mj_forward(model, data)
    robot = Controller(
        model=model,
        data=data,
        robot_type=robot_type,
        ee_site_name=site,
        arm_joint_names=[f"{prefix}joint_{i}" for i in range(6)],
        gripper_joint_names=[f"{prefix}left_carriage_joint"],
        ik_scale=1.0,
        ik_damping=0.03,
    )
    target = robot.get_ee_pose()[0] + np.array([0.03, 0.0, -0.04])
    for _ in range(400):
        robot.set_ee_pose(target, position_only=True)
        mujoco.mj_step(model, data)
    assert np.linalg.norm(robot.get_ee_pose()[0] - target) < 0.005


# -- (c) the vendor's public attributes and constants ----------------------------------------
def _id(model: mujoco.MjModel, kind: str, name: str) -> int:
    index = mujoco.mj_name2id(model, getattr(mujoco.mjtObj, f"mjOBJ_{kind.upper()}"), name)
    assert index >= 0, f"no {kind} {name}"
    return index


ATTRIBUTE_CASES = {
    # id: (scene, robot type, ee site, joint names given (vendor's) or None, this project's
    #      arm joint prefix, its gripper actuator)
    "wxai defaults": (
        "wxai/scene_wxai_pick_place.xml",
        RobotType.WXAI,
        "ee_site",
        None,
        "",
        "gripper",
    ),
    "wxai named": ("wxai/scene_wxai_pick_place.xml", RobotType.WXAI, "ee_site", "", "", "gripper"),
    "stationary left": (
        "stationary_ai/scene_stationary_ai_pick_place.xml",
        RobotType.STATIONARY_AI,
        "follower_left_ee_site",
        _LEFT,
        "left/",
        "left/gripper",
    ),
    "mobile right": (
        "mobile_ai/scene_mobile_ai_pick_place.xml",
        RobotType.MOBILE_AI,
        "follower_right_ee_site",
        _RIGHT,
        "right/",
        "right/gripper",
    ),
}


@pytest.mark.parametrize(
    ("scene", "robot_type", "site", "given", "prefix", "gripper_actuator"),
    ATTRIBUTE_CASES.values(),
    ids=list(ATTRIBUTE_CASES),
)
def test_the_vendors_attributes_as_its_controller_defines_them(
    scene, robot_type, site, given, prefix, gripper_actuator
):
    """As the vendor's __init__ builds them: per arm joint name its joint id, qpos and dof
    address and the actuator of the same name; per gripper joint name its joint id, qpos
    address and the gripper's actuator (on the WidowX AI, by default joint_0..5 and
    left_carriage_joint); lists of ints; (3, nv) zero Jacobians."""
    model = _load(scene)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    kwargs = {}
    if given is not None:
        kwargs["arm_joint_names"] = [f"{given}joint_{i}" for i in range(6)]
        kwargs["gripper_joint_names"] = [f"{given}left_carriage_joint"]
    robot = Controller(model, data, robot_type, ee_site_name=site, **kwargs)
    arm = [_id(model, "joint", f"{prefix}joint_{i}") for i in range(6)]
    finger = _id(model, "joint", f"{prefix}left_carriage_joint")
    assert robot.arm_joint_ids == arm
    assert robot.arm_qpos_indices == [model.jnt_qposadr[j] for j in arm]
    assert robot.arm_dof_indices == [model.jnt_dofadr[j] for j in arm]
    assert robot.arm_actuator_ids == [
        _id(model, "actuator", f"{prefix}joint_{i}") for i in range(6)
    ]
    assert robot.gripper_joint_ids == [finger]
    assert robot.gripper_qpos_indices == [model.jnt_qposadr[finger]]
    assert robot.gripper_actuator_ids == [_id(model, "actuator", gripper_actuator)]
    assert robot.num_arm_joints == 6
    for ids in (robot.arm_joint_ids, robot.arm_actuator_ids, robot.gripper_qpos_indices):
        assert type(ids) is list and all(type(i) is int for i in ids)
    assert robot.ee_site_id == _id(
        model, "site", site.replace("follower_", "").replace("_ee", "/ee")
    )
    assert robot.jac_pos.shape == robot.jac_rot.shape == (3, model.nv)
    assert not robot.jac_pos.any() and not robot.jac_rot.any()


def test_the_jacobians_are_the_tool_frames_after_an_ik_step():
    """jac_pos / jac_rot: mj_jacSite at the tool frame, as the vendor's compute_ik_step (and so
    its set_ee_pose) fills them."""
    model = _load("wxai/scene_wxai_pick_place.xml")
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    robot = Controller(model, data, RobotType.WXAI)
    expected_pos, expected_rot = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jacSite(model, data, expected_pos, expected_rot, robot.ee_site_id)
    dq = robot.compute_ik_step(np.array([0.3, 0.05, 0.15]), np.array([1.0, 0.0, 0.0, 0.0]))
    np.testing.assert_array_equal(robot.jac_pos, expected_pos)
    np.testing.assert_array_equal(robot.jac_rot, expected_rot)
    assert dq.shape == (6,)
    # and the position part of the vendor's step, from those Jacobians
    jac = robot.jac_pos[:, robot.arm_dof_indices]
    err = np.array([0.3, 0.05, 0.15]) - robot.get_ee_pose()[0]
    step = robot.ik_scale * jac.T @ np.linalg.solve(jac @ jac.T + 0.03**2 * np.eye(3), err)
    np.testing.assert_allclose(robot.compute_ik_step([0.3, 0.05, 0.15]), step, atol=1e-9)


def test_the_vendors_constants_and_gripper_commands():
    assert (vendor_api.GRIPPER_OPEN_POSITION, vendor_api.GRIPPER_CLOSED_POSITION) == (0.044, 0.022)
    assert (vendor_api.DEFAULT_IK_SCALE, vendor_api.DEFAULT_IK_DAMPING) == (0.5, 0.03)
    model = _load("wxai/scene_wxai_pick_place.xml")
    data = mujoco.MjData(model)
    robot = Controller(model, data)
    robot.set_gripper_position(0.03)
    assert data.ctrl[robot.gripper_actuator_ids[0]] == pytest.approx(0.03)
    robot.open_gripper()
    assert data.ctrl[robot.gripper_actuator_ids[0]] == vendor_api.GRIPPER_OPEN_POSITION
    for _ in range(300):
        mujoco.mj_step(model, data)
    assert robot.get_gripper_position() == data.qpos[robot.gripper_qpos_indices[0]]
    assert robot.get_gripper_position() == pytest.approx(0.044, abs=1e-3)


def test_the_kits_default_gripper_is_the_arms_own():
    """Where the vendor's defaults give a kit arm no gripper (empty lists), this layer gives
    the arm's own: its actuated finger (docs/vendor-api.md)."""
    model = _load("stationary_ai/scene_joint.xml")
    robot = Controller(model, mujoco.MjData(model), "stationary_ai", "right/ee_site")
    assert robot.gripper_joint_ids == [_id(model, "joint", "right/left_carriage_joint")]
    assert robot.gripper_actuator_ids == [_id(model, "actuator", "right/gripper")]
