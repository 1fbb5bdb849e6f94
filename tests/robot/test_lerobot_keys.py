"""LeRobot's feature keys and joint value names: defined once, in ``robot.lerobot_keys``."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import trossen_arm_mujoco
from trossen_arm_mujoco.robot import lerobot_keys as keys
from trossen_arm_mujoco.robot.layout import KIT14_LAYOUT, VENDOR16_LAYOUT

PACKAGE_DIR = Path(trossen_arm_mujoco.__file__).parent
PLUGIN_DIR = PACKAGE_DIR.parent / "plugins"


def test_keys_are_lerobots():
    assert (keys.STATE_KEY, keys.VELOCITY_KEY, keys.ACTION_KEY) == (
        "observation.state",
        "observation.velocity",
        "action",
    )
    assert keys.ENV_STATE_KEY == "observation.environment_state"
    assert keys.image_key("cam_high") == "observation.images.cam_high"
    assert keys.image_camera("observation.images.cam_left_wrist") == "cam_left_wrist"
    assert keys.image_camera("observation.state") is None


def test_joint_value_names_and_quantities():
    assert keys.joint_value_names(["left_joint_0", "x"]) == ("left_joint_0.pos", "x.pos")
    assert keys.joint_value_names(["left_joint_0"], "eff") == ("left_joint_0.eff",)
    assert KIT14_LAYOUT.names[0] == "left_joint_0.pos"
    assert keys.with_quantity(KIT14_LAYOUT.names[:2], "vel") == [
        "left_joint_0.vel",
        "left_joint_1.vel",
    ]
    vendor = list(VENDOR16_LAYOUT.names)  # no ".pos": unchanged
    assert keys.with_quantity(vendor, "vel") == vendor
    with pytest.raises(ValueError, match="quantity must be one of"):
        keys.joint_value_names(["left_joint_0"], "acc")


def _code_strings(path: Path) -> list[tuple[int, str]]:
    """String constants of ``path`` outside docstrings (f-string parts included)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docstrings = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr):
            value = body[0].value
            if isinstance(value, ast.Constant) and isinstance(value.value, str):
                docstrings.add(id(value))
    return [
        (node.lineno, node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant)
        and isinstance(node.value, str)
        and id(node) not in docstrings
    ]


def test_no_module_spells_a_feature_key_itself():
    spelled = {keys.STATE_KEY, keys.VELOCITY_KEY, keys.ENV_STATE_KEY, keys.IMAGE_KEY_PREFIX}
    own = PACKAGE_DIR / "robot" / "lerobot_keys.py"
    paths = [*PACKAGE_DIR.rglob("*.py"), *PLUGIN_DIR.rglob("*.py")]
    found = [
        f"{path.relative_to(PACKAGE_DIR.parent)}:{line}: {text!r}"
        for path in sorted(paths)
        if path != own
        for line, text in _code_strings(path)
        if text in spelled
    ]
    assert not found, "use robot.lerobot_keys instead:\n" + "\n".join(found)
