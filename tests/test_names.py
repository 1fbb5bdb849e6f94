"""names: listing and looking up model elements; errors list the valid names."""

from __future__ import annotations

from pathlib import Path

import mujoco
import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR
from trossen_arm_mujoco.errors import UserError, unknown_name_error
from trossen_arm_mujoco.names import _OBJ, lookup_id, names_of

KIT = Path(ASSETS_DIR) / "stationary_ai/trossen_ai_scene.xml"


@pytest.fixture(scope="module")
def model():
    return mujoco.MjModel.from_xml_path(str(KIT))


def test_names_of_every_kind(model):
    assert names_of(model, "camera") == ["cam_high", "cam_low", "cam_left_wrist", "cam_right_wrist"]
    assert names_of(model, "actuator") == ["left/gripper", "right/gripper"]
    assert names_of(model, "key") == ["home"]
    assert "red_box_joint" in names_of(model, "joint")
    assert "mocap_left" in names_of(model, "body")
    assert "left/ee_site" in names_of(model, "site")
    assert "mocap_right_weld" in names_of(model, "equality")
    geoms = names_of(model, "geom")
    assert "" not in geoms  # unnamed geoms are skipped
    assert len(geoms) < model.ngeom


def test_lookup_id_matches_mujoco(model):
    for kind, (obj, _) in _OBJ.items():
        for name in names_of(model, kind):
            assert lookup_id(model, kind, name) == mujoco.mj_name2id(model, obj, name)


@pytest.mark.parametrize(
    ("kind", "name", "valid"),
    [
        ("joint", "left/joint_6", "left/joint_0"),
        ("camera", "cam_top", "cam_right_wrist"),
        ("site", "ee_site", "left/ee_site"),
        ("geom", "cube", "red_box"),
        ("body", "mocap", "mocap_left"),
        ("actuator", "left/joint_0", "left/gripper"),
    ],
)
def test_unknown_name_lists_valid_names(model, kind, name, valid):
    with pytest.raises(UserError) as err:
        lookup_id(model, kind, name)
    msg = str(err.value)
    assert msg.startswith(f"unknown {kind} '{name}'; valid {kind}s: ")
    assert valid in msg
    assert "\n" not in msg


def test_unknown_name_error_sorted_and_hint():
    err = unknown_name_error("camera", "x", ["b", "a"], hint="see the docs")
    assert str(err) == "unknown camera 'x'; valid cameras: a, b (see the docs)"
