"""The wxai URDF parses and describes the same kinematics as the MJCF."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import mujoco
import numpy as np
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR

ASSETS = Path(ASSETS_DIR)
URDF = ASSETS / "wxai" / "wxai_follower.urdf"
MJCF = ASSETS / "wxai" / "wxai_follower.xml"


def floats(text: str | None) -> np.ndarray:
    return np.array([float(v) for v in (text or "").split()])


@pytest.fixture(scope="module")
def urdf() -> ET.Element:
    return ET.parse(URDF).getroot()


@pytest.fixture(scope="module")
def mjcf() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(MJCF))


def movable_joints(root: ET.Element) -> dict[str, ET.Element]:
    return {j.get("name"): j for j in root.iter("joint") if j.get("type") != "fixed"}


def test_urdf_parses(urdf):
    assert urdf.tag == "robot"
    links = {link.get("name") for link in urdf.iter("link")}
    for joint in urdf.iter("joint"):  # every joint connects known links
        assert joint.find("parent").get("link") in links
        assert joint.find("child").get("link") in links


def test_same_joint_names_in_order(urdf, mjcf):
    mj_names = [mjcf.joint(i).name for i in range(mjcf.njnt)]
    assert list(movable_joints(urdf)) == mj_names


def test_joint_types_axes_limits_origins(urdf, mjcf):
    for name, joint in movable_joints(urdf).items():
        j = mjcf.joint(name)
        expected_type = "revolute" if j.type[0] == mujoco.mjtJoint.mjJNT_HINGE else "prismatic"
        assert joint.get("type") == expected_type, name
        np.testing.assert_allclose(floats(joint.find("axis").get("xyz")), j.axis, atol=1e-12)
        limit = joint.find("limit")
        np.testing.assert_allclose(
            [float(limit.get("lower")), float(limit.get("upper"))], j.range, atol=1e-9
        )
        assert float(limit.get("velocity")) > 0 and float(limit.get("effort")) > 0
        # joint origin = the child body's offset in its parent (MJCF joints sit at the body
        # origin and every body frame is unrotated)
        child = mjcf.body(joint.find("child").get("link"))
        parent = mjcf.body(joint.find("parent").get("link"))
        assert child.parentid[0] == parent.id
        origin = joint.find("origin")
        np.testing.assert_allclose(floats(origin.get("xyz")), child.pos, atol=1e-9)
        np.testing.assert_allclose(floats(origin.get("rpy") or "0 0 0"), 0.0, atol=1e-12)
        np.testing.assert_allclose(child.quat, [1, 0, 0, 0], atol=1e-12)
        np.testing.assert_allclose(j.pos, 0.0, atol=1e-12)


def test_same_link_masses(urdf, mjcf):
    for link in urdf.iter("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        mass = float(inertial.find("mass").get("value"))
        np.testing.assert_allclose(mass, mjcf.body(link.get("name")).mass[0], rtol=1e-6)


def test_ee_gripper_frame_matches_ee_site(urdf, mjcf):
    fixed = {j.get("name"): j for j in urdf.iter("joint") if j.get("type") == "fixed"}
    ee = fixed["ee_gripper"]
    assert ee.find("parent").get("link") == "link_6"
    site = mjcf.site("ee_site")
    assert site.bodyid[0] == mjcf.body("link_6").id
    np.testing.assert_allclose(floats(ee.find("origin").get("xyz")), site.pos, atol=1e-9)


def test_gripper_mimic_matches_mjcf_coupling(urdf, mjcf):
    right = movable_joints(urdf)["right_carriage_joint"]
    mimic = right.find("mimic")
    assert mimic is not None and mimic.get("joint") == "left_carriage_joint"
    assert float(mimic.get("multiplier")) == 1.0
    eq = mjcf.equality("gripper_coupling")
    assert mjcf.joint(int(eq.obj1id[0])).name == "right_carriage_joint"
    assert mjcf.joint(int(eq.obj2id[0])).name == "left_carriage_joint"
    np.testing.assert_allclose(eq.data[:5], [0, 1, 0, 0, 0])
