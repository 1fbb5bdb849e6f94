"""The joint layouts: the HDF5 files' 16 values and the real kit's 14 (LeRobot, the driver)."""

from __future__ import annotations

import numpy as np
import pytest

from trossen_arm_mujoco.robot.layout import (
    EXPORT_LAYOUTS,
    KIT14_LAYOUT,
    LAYOUTS,
    MOBILEAI_LAYOUT,
    START_ARM_POSE,
    VENDOR16_LAYOUT,
    WIDOWXAI_LAYOUT,
    kit_joint_commands,
)

#: The values of Trossen's LeRobot plugin for the kit (``bi_widowxai_follower_robot``), in
#: its order: written down as facts, not derived from the code under test.
PLUGIN_NAMES = [
    "left_joint_0.pos",
    "left_joint_1.pos",
    "left_joint_2.pos",
    "left_joint_3.pos",
    "left_joint_4.pos",
    "left_joint_5.pos",
    "left_left_carriage_joint.pos",
    "right_joint_0.pos",
    "right_joint_1.pos",
    "right_joint_2.pos",
    "right_joint_3.pos",
    "right_joint_4.pos",
    "right_joint_5.pos",
    "right_left_carriage_joint.pos",
]
PLUGIN_UNITS = ["rad"] * 6 + ["m"] + ["rad"] * 6 + ["m"]


def test_real_kit_names_and_units_are_the_plugins():
    assert list(KIT14_LAYOUT.names) == PLUGIN_NAMES
    assert list(KIT14_LAYOUT.units) == PLUGIN_UNITS
    assert KIT14_LAYOUT.size == 14
    assert set(LAYOUTS) == {"kit14", "vendor16", "mobileai"}
    assert LAYOUTS["kit14"] is KIT14_LAYOUT and LAYOUTS["vendor16"] is VENDOR16_LAYOUT
    assert LAYOUTS["mobileai"] is MOBILEAI_LAYOUT
    assert EXPORT_LAYOUTS == {**LAYOUTS, "widowxai": WIDOWXAI_LAYOUT}


def test_widowxai_is_one_followers_seven_values():
    # Trossen's widowxai_follower_robot: config.joint_names joint_0..joint_5,
    # left_carriage_joint, each "<joint>.pos" (lerobot_robot_trossen/widowxai_follower.py)
    assert list(WIDOWXAI_LAYOUT.names) == [n.removeprefix("left_") for n in PLUGIN_NAMES[:7]]
    assert list(WIDOWXAI_LAYOUT.units) == PLUGIN_UNITS[:7] and WIDOWXAI_LAYOUT.size == 7
    seven = np.arange(7.0)  # a single arm's recording: 6 joints, the gripper
    np.testing.assert_array_equal(WIDOWXAI_LAYOUT.from_vendor(seven), seven)
    with pytest.raises(ValueError, match="7 values"):
        WIDOWXAI_LAYOUT.from_vendor(np.zeros(16))


def test_mobileai_is_the_kits_14_then_the_base():
    # Trossen's mobileai_robot: the bimanual arms' features, then {"x.vel", "theta.vel"}
    # (lerobot_robot_trossen/mobileai.py, _base_ft)
    assert list(MOBILEAI_LAYOUT.names) == PLUGIN_NAMES + ["x.vel", "theta.vel"]
    assert list(MOBILEAI_LAYOUT.units) == PLUGIN_UNITS + ["m/s", "rad/s"]
    action = np.arange(16.0)
    commands = MOBILEAI_LAYOUT.commands(action)
    np.testing.assert_array_equal(commands["left_arm"], range(6))
    np.testing.assert_array_equal(commands["left_gripper"], [6])
    np.testing.assert_array_equal(commands["right_arm"], range(7, 13))
    np.testing.assert_array_equal(commands["right_gripper"], [13])
    np.testing.assert_array_equal(commands["base"], [14, 15])
    np.testing.assert_array_equal(MOBILEAI_LAYOUT.from_vendor(action), action)
    with pytest.raises(ValueError, match="16 values"):
        MOBILEAI_LAYOUT.commands(np.zeros(14))


def test_from_vendor_keeps_the_actuated_finger_and_drops_the_coupled_one():
    vendor = np.arange(16.0)
    kit = KIT14_LAYOUT.from_vendor(vendor)
    # the carriage value is left_carriage_joint: index 7 / 15 of the 16
    np.testing.assert_array_equal(kit, [0, 1, 2, 3, 4, 5, 7, 8, 9, 10, 11, 12, 13, 15])
    for name, value in zip(KIT14_LAYOUT.names, kit, strict=True):
        assert VENDOR16_LAYOUT.names[int(value)] == name.removesuffix(".pos")
    batch = np.random.default_rng(0).normal(size=(3, 5, 16))
    assert KIT14_LAYOUT.from_vendor(batch).shape == (3, 5, 14)
    with pytest.raises(ValueError, match="16 values"):
        KIT14_LAYOUT.from_vendor(np.zeros(14))


def test_to_vendor_round_trip():
    kit = np.random.default_rng(1).normal(size=(4, 14))
    vendor = KIT14_LAYOUT.to_vendor(kit)
    assert vendor.shape == (4, 16)
    np.testing.assert_array_equal(KIT14_LAYOUT.from_vendor(vendor), kit)
    # the coupled finger (6 / 14) repeats the gripper value
    np.testing.assert_array_equal(vendor[:, 6], kit[:, 6])
    np.testing.assert_array_equal(vendor[:, 14], kit[:, 13])
    start = np.array(START_ARM_POSE)  # both fingers equal: vendor -> kit -> vendor is exact
    np.testing.assert_array_equal(KIT14_LAYOUT.to_vendor(KIT14_LAYOUT.from_vendor(start)), start)
    with pytest.raises(ValueError, match="14 values"):
        KIT14_LAYOUT.to_vendor(np.zeros(16))


def test_kit_joint_commands_equal_for_14_and_16_values():
    vendor = np.random.default_rng(2).uniform(-1, 1, size=16)
    vendor[[6, 14]] = 123.0  # the coupled fingers are not commanded
    from_16 = kit_joint_commands(vendor)
    from_14 = kit_joint_commands(KIT14_LAYOUT.from_vendor(vendor))
    assert (
        list(from_16)
        == list(from_14)
        == [
            "left_arm",
            "left_gripper",
            "right_arm",
            "right_gripper",
        ]
    )
    for group in from_16:
        np.testing.assert_array_equal(from_14[group], from_16[group])
    np.testing.assert_array_equal(from_16["left_gripper"], vendor[[7]])
    np.testing.assert_array_equal(from_16["right_arm"], vendor[8:14])
    for bad in (np.zeros(15), np.zeros(17), np.zeros((2, 16)), np.float64(0.0)):
        with pytest.raises(ValueError, match="14 values .* or 16"):
            kit_joint_commands(bad)


def test_layouts_are_named_after_their_keys():
    from trossen_arm_mujoco.robot import layout

    assert LAYOUTS["kit14"] is KIT14_LAYOUT and LAYOUTS["vendor16"] is VENDOR16_LAYOUT
    assert (KIT14_LAYOUT.size, VENDOR16_LAYOUT.size) == (14, 16)
    assert type(KIT14_LAYOUT).__name__ == "Kit14Layout"
    assert type(VENDOR16_LAYOUT).__name__ == "Vendor16Layout"
    for old in ("KIT_LAYOUT", "REAL_KIT_LAYOUT", "KitLayout", "RealKitLayout"):
        assert not hasattr(layout, old)  # renamed, no shim (tests/test_import_graph.py)
