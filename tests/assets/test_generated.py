"""The shipped models are exactly what ``tools/build_models.py`` generates.

If this fails after editing the robot facts in tools/build_models.py, regenerate the models
with ``python tools/build_models.py`` (from the repo root) and commit them.
"""

from __future__ import annotations

import difflib
import importlib.util
from pathlib import Path

import pytest

from trossen_arm_mujoco.constants import ASSETS_DIR

REPO = Path(__file__).resolve().parents[2]
BUILD_MODELS = REPO / "tools" / "build_models.py"


def load_build_models():
    if not BUILD_MODELS.is_file():
        pytest.skip(f"{BUILD_MODELS} is not in this checkout (installed package only)")
    spec = importlib.util.spec_from_file_location("build_models_under_test", BUILD_MODELS)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def generated() -> dict[str, str]:
    return load_build_models().generate()


def test_generator_covers_the_robot_models(generated):
    assert {
        "wxai/wxai_follower.xml",
        "wxai/wxai_follower.urdf",
        "stationary_ai/trossen_ai.xml",
        "stationary_ai/trossen_ai_scene.xml",
        "stationary_ai/trossen_ai_scene_joint.xml",
    } <= set(generated)


def test_generator_writes_into_the_package_assets():
    module = load_build_models()
    assert Path(module.ASSETS).resolve() == Path(ASSETS_DIR).resolve()


def test_committed_models_are_up_to_date(generated):
    stale = []
    for rel, text in sorted(generated.items()):
        path = Path(ASSETS_DIR) / rel
        if not path.is_file():
            stale.append(f"{rel}: missing")
            continue
        shipped = path.read_text()
        if shipped != text:
            diff = difflib.unified_diff(
                shipped.splitlines(), text.splitlines(), "shipped", "generated", lineterm="", n=1
            )
            stale.append(f"{rel}:\n" + "\n".join(list(diff)[:20]))
    assert not stale, "run `python tools/build_models.py`; stale models:\n" + "\n".join(stale)


def test_generation_is_deterministic(generated):
    assert load_build_models().generate() == generated
