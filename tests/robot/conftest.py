"""Small inline models for the robot-layer tests: a 3-joint arm (hinge, hinge with an
anchor offset and ``ref``, slide) with a rotated tool site and a two-finger gripper, hanging
from a base that is fixed, a mocap body or on a free joint."""

from __future__ import annotations

from types import SimpleNamespace

import mujoco
import pytest

from trossen_arm_mujoco.assets import ASSETS_DIR
from trossen_arm_mujoco.robot.arm_groups import ArmMoveGroup
from trossen_arm_mujoco.robot.configs import MoveGroupSpec, RobotConfig

_BASE = {
    "fixed": '<body name="base" pos="0.1 -0.2 0.3" quat="0.9238795 0 0 0.3826834">',
    "mocap": '<body name="base" mocap="true" pos="0.1 -0.2 0.3" quat="0.9238795 0 0 0.3826834">',
    "free": '<body name="base" pos="0.1 -0.2 0.3" quat="0.9238795 0 0 0.3826834">'
    '<freejoint name="base_free"/>',
}


def toy_xml(base: str = "fixed") -> str:
    """The toy arm on a base of kind ``base`` ("fixed", "mocap" or "free")."""
    return f"""
<mujoco>
  <compiler angle="radian"/>
  <worldbody>
    {_BASE[base]}
      <geom type="box" size="0.05 0.05 0.02" mass="1"/>
      <body name="link1" pos="0 0 0.1">
        <joint name="j1" type="hinge" axis="0 0 1" range="-2 2"/>
        <geom type="capsule" size="0.02" fromto="0 0 0 0.2 0 0" mass="0.5"/>
        <body name="link2" pos="0.2 0 0" quat="0.9659258 0.2588190 0 0">
          <joint name="j2" type="hinge" axis="0 1 0" pos="0.01 0.02 0" ref="0.3" limited="false"/>
          <geom type="capsule" size="0.02" fromto="0 0 0 0.2 0 0" mass="0.5"/>
          <body name="link3" pos="0.2 0 0">
            <joint name="j3" type="slide" axis="1 0 0" range="0 0.1"/>
            <geom type="box" size="0.03 0.03 0.03" mass="0.2"/>
            <site name="tool" pos="0.05 0.01 0" quat="0.7071068 0.7071068 0 0"/>
            <body name="finger_a" pos="0.05 0.02 0">
              <joint name="fa" type="slide" axis="0 1 0" range="0 0.03"/>
              <geom type="box" size="0.01 0.005 0.01" mass="0.05"/>
            </body>
            <body name="finger_b" pos="0.05 -0.02 0">
              <joint name="fb" type="slide" axis="0 -1 0" range="0 0.03"/>
              <geom type="box" size="0.01 0.005 0.01" mass="0.05"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="a1" joint="j1" kp="10" ctrlrange="-2 2"/>
    <position name="a2" joint="j2" kp="10" ctrlrange="-3 3"/>
    <position name="a3" joint="j3" kp="10" ctrlrange="0 0.1"/>
    <position name="grip" joint="fa" kp="10" ctrlrange="0 0.03"/>
  </actuator>
  <equality><joint joint1="fb" joint2="fa"/></equality>
</mujoco>
"""


def toy_config(base: str = "fixed") -> RobotConfig:
    """Config of the toy arm: base, arm (j1, j2, j3; tool site), gripper (fa, fb)."""
    kind = {"fixed": "base", "mocap": "mocap_base", "free": "free_joint_base"}[base]
    base_spec = (
        MoveGroupSpec(kind, joints=("base_free",))
        if base == "free"
        else MoveGroupSpec(kind, base_body="base")
    )
    return RobotConfig(
        "toy",
        {
            "base": base_spec,
            "arm": MoveGroupSpec(
                "arm", ("j1", "j2", "j3"), ("a1", "a2", "a3"), "tool", base="base"
            ),
            "gripper": MoveGroupSpec("gripper", ("fa", "fb"), ("grip",), base="base"),
        },
        init_qpos={"arm": [0.3, 0.5, 0.02], "gripper": [0.03, 0.03]},
        command_mode={"arm": "joint_position", "gripper": "joint_position"},
    )


@pytest.fixture
def toy_model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(toy_xml("fixed"))


def toy_arm(model_or_data, frame: str = "tool", frame_type: str = "site") -> ArmMoveGroup:
    """The toy arm's joints (j1, j2, j3) as an ``ArmMoveGroup`` with leaf frame ``frame``."""
    return ArmMoveGroup(
        model_or_data, "arm", ["j1", "j2", "j3"], ["a1", "a2", "a3"], frame, frame_type
    )


@pytest.fixture
def toy():
    """The factories: ``toy.xml(base)``, ``toy.config(base)``, ``toy.model(base)``,
    ``toy.arm(model_or_data, frame="tool", frame_type="site")``."""

    def model(base: str = "fixed") -> mujoco.MjModel:
        return mujoco.MjModel.from_xml_string(toy_xml(base))

    return SimpleNamespace(xml=toy_xml, config=toy_config, model=model, arm=toy_arm)


@pytest.fixture(scope="session")
def wxai() -> mujoco.MjModel:
    """The single wxai arm (``assets/wxai/wxai_follower.xml``)."""
    return mujoco.MjModel.from_xml_path(f"{ASSETS_DIR}/wxai/wxai_follower.xml")


@pytest.fixture(scope="session")
def kit_joint() -> mujoco.MjModel:
    """The kit's joint-controlled scene."""
    return mujoco.MjModel.from_xml_path(f"{ASSETS_DIR}/stationary_ai/trossen_ai_scene_joint.xml")


@pytest.fixture(scope="session")
def kit_mocap() -> mujoco.MjModel:
    """The kit's mocap (end-effector) scene."""
    return mujoco.MjModel.from_xml_path(f"{ASSETS_DIR}/stationary_ai/trossen_ai_scene.xml")
