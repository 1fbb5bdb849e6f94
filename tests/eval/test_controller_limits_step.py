"""The arm controller's limits carried by a checkpoint's saved processors
(``eval.controller_limits_step``): how they are written, and (where LeRobot is installed)
what the two steps do to an action."""

from __future__ import annotations

import importlib.util
import json
import os
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import controller_limits_step as cls
from trossen_arm_mujoco.export.dataset_settings import (
    CHECKPOINT_FILE,
    DatasetSettings,
    write_checkpoint_settings,
)
from trossen_arm_mujoco.real.controller_checks import controller_limits


def _checkpoint(
    folder: Path, size: int = 14, fps: float | None = 50, layout: str = "kit14"
) -> Path:
    """The files of a LeRobot checkpoint that the steps touch (no weights)."""
    folder.mkdir(parents=True)
    config = {"output_features": {"action": {"type": "ACTION", "shape": [size]}}}
    (folder / "config.json").write_text(json.dumps(config))
    pre = {
        "name": "policy_preprocessor",
        "steps": [
            {"registry_name": "to_batch_processor", "config": {}},
            {"registry_name": "normalizer_processor", "config": {}},
        ],
    }
    post = {
        "name": "policy_postprocessor",
        "steps": [
            {"registry_name": "unnormalizer_processor", "config": {}},
            {"registry_name": "device_processor", "config": {}},
        ],
    }
    (folder / cls.PREPROCESSOR_FILE).write_text(json.dumps(pre))
    (folder / cls.POSTPROCESSOR_FILE).write_text(json.dumps(post))
    if fps is not None:
        settings = DatasetSettings(fps=fps, layout=layout, task="sim_transfer_cube")
        write_checkpoint_settings(folder, settings)
    return folder


def _names(path: Path) -> list[str]:
    return [s["registry_name"] for s in json.loads(path.read_text())["steps"]]


def test_both_steps_are_added_in_place_once(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt")
    assert cls.add_to_checkpoint(ckpt) is True
    assert _names(ckpt / cls.PREPROCESSOR_FILE) == [
        "to_batch_processor",
        cls.MEASURED_NAME,
        "normalizer_processor",
    ]
    assert _names(ckpt / cls.POSTPROCESSOR_FILE) == [
        "unnormalizer_processor",
        cls.REGISTRY_NAME,
        "device_processor",
    ]
    before = (ckpt / cls.POSTPROCESSOR_FILE).read_text()
    assert cls.add_to_checkpoint(ckpt) is False  # already as it would be written
    assert (ckpt / cls.POSTPROCESSOR_FILE).read_text() == before
    post = json.loads(before)["steps"][1]["config"]
    pre = json.loads((ckpt / cls.PREPROCESSOR_FILE).read_text())["steps"][1]["config"]
    assert post["link"] == pre["link"] and len(post["link"]) == 16


def test_joint_steps_follow_the_speed_limits_at_the_checkpoints_rate(tmp_path):
    lims = controller_limits()
    steps50 = cls.joint_steps(14, 50)
    assert steps50[1] == pytest.approx(cls.SPEED_MARGIN * lims[1].velocity_max * 3 / 50)
    assert steps50[6] == 0.0 and steps50[13] == 0.0  # grippers are not held to their width
    assert steps50[7:] == steps50[:7]
    assert cls.joint_steps(14, 30)[0] == pytest.approx(steps50[0] * 50 / 30)
    assert len(cls.joint_steps(16, 50)) == 16
    ckpt = _checkpoint(tmp_path / "ckpt", fps=30)
    cls.add_to_checkpoint(ckpt)
    config = json.loads((ckpt / cls.POSTPROCESSOR_FILE).read_text())["steps"][1]["config"]
    assert config["max_step"] == pytest.approx(cls.joint_steps(14, 30))
    with pytest.raises(UserError, match="fps must be a positive finite number"):
        cls.joint_steps(14, 0)
    assert cls.joint_steps(7, 50) == pytest.approx(steps50[:7])  # a single arm's 7
    with pytest.raises(UserError, match="the actions have 8 values; .* a single arm's 7"):
        cls.joint_steps(8, 50)


def test_a_mobile_ai_checkpoint_gets_its_base_limits_not_the_vendors_grippers(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt", size=16, layout="mobileai")
    cls.add_to_checkpoint(ckpt)
    config = json.loads((ckpt / cls.POSTPROCESSOR_FILE).read_text())["steps"][1]["config"]
    kit_low, kit_high = cls.controller_bounds(14)
    assert config["low"] == kit_low + [-1.0, -1.0] and config["high"] == kit_high + [1.0, 1.0]
    assert config["max_step"] == cls.joint_steps(14, 50) + [0.0, 0.0]
    vendor_low, _ = cls.controller_bounds(16)
    assert vendor_low[6] == vendor_low[7] == 0.0 and config["low"][7] == kit_low[7]


def test_without_a_rate_only_the_range_is_clipped(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt", fps=None)
    assert cls.add_to_checkpoint(ckpt) is True
    assert cls.MEASURED_NAME not in _names(ckpt / cls.PREPROCESSOR_FILE)
    config = json.loads((ckpt / cls.POSTPROCESSOR_FILE).read_text())["steps"][1]["config"]
    assert set(config) == {"low", "high"}
    # a rate given later brings the step up to date
    assert cls.add_to_checkpoint(ckpt, fps=50) is True
    assert cls.MEASURED_NAME in _names(ckpt / cls.PREPROCESSOR_FILE)


def test_an_older_range_only_step_is_brought_up_to_date(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt")
    post = json.loads((ckpt / cls.POSTPROCESSOR_FILE).read_text())
    low, high = cls.controller_bounds(14)
    post["steps"].insert(
        1, {"registry_name": cls.REGISTRY_NAME, "config": {"low": low, "high": high}}
    )
    (ckpt / cls.POSTPROCESSOR_FILE).write_text(json.dumps(post))
    assert cls.add_to_checkpoint(ckpt) is True
    names = _names(ckpt / cls.POSTPROCESSOR_FILE)
    assert names.count(cls.REGISTRY_NAME) == 1
    assert (
        "max_step" in json.loads((ckpt / cls.POSTPROCESSOR_FILE).read_text())["steps"][1]["config"]
    )


def test_a_folder_that_is_not_a_checkpoint_is_one_line(tmp_path, capsys):
    with pytest.raises(UserError, match="no config.json there; give a LeRobot checkpoint folder"):
        cls.add_to_checkpoint(tmp_path)
    ckpt = _checkpoint(tmp_path / "ckpt")
    (ckpt / CHECKPOINT_FILE).write_text("{not json")
    with pytest.raises(UserError, match="trossen_settings.json: cannot read it"):
        cls.add_to_checkpoint(ckpt)
    assert cls.main([str(tmp_path / "nothing")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and len(err.strip().splitlines()) == 1


def _lerobot_in_process() -> None:
    """The steps run LeRobot in this process: on the 3.12 leg (this module is py312). On a
    Python without LeRobot while the suite's venv is set up (tools/run_tests.sh's leg 1), the
    3.12 leg runs these tests; with no venv at all, a plain importorskip."""
    if importlib.util.find_spec("lerobot") is None and os.environ.get("TROSSEN_LEROBOT_PYTHON"):
        pytest.skip("run by the Python 3.12 leg of tools/run_tests.sh (marker py312)")
    pytest.importorskip("lerobot")


def _steps(ckpt: Path):
    """The two steps as LeRobot builds them from the saved JSON."""
    from lerobot.processor import ProcessorStepRegistry

    cls.register()
    cls.register()  # twice is fine

    def build(path: Path, name: str):
        step = next(s for s in json.loads(path.read_text())["steps"] if s["registry_name"] == name)
        return ProcessorStepRegistry.get(name)(**step["config"])

    return (
        build(ckpt / cls.PREPROCESSOR_FILE, cls.MEASURED_NAME),
        build(ckpt / cls.POSTPROCESSOR_FILE, cls.REGISTRY_NAME),
    )


@pytest.fixture
def built(tmp_path):
    """torch, LeRobot's TransitionKey and the two steps of a fresh checkpoint at 50 fps."""
    torch = pytest.importorskip("torch")
    _lerobot_in_process()
    from lerobot.processor import TransitionKey

    ckpt = _checkpoint(tmp_path / "ckpt")
    cls.add_to_checkpoint(ckpt)
    return (torch, TransitionKey, *_steps(ckpt))


def test_the_steps_hold_each_joint_near_its_measured_position(built):
    torch, TransitionKey, measured_step, limits_step = built
    state = torch.tensor([[0.0, 0.2618, 0.2618, 0.0, 0.0, 0.0, 0.044] * 2])
    obs = {"observation.state": state, "observation.environment_state": torch.zeros(1, 7)}
    out = measured_step({TransitionKey.OBSERVATION: obs})[TransitionKey.OBSERVATION]
    assert torch.equal(out["observation.state"], state)  # the observation is unchanged
    far = state.clone()
    far[0, 8] -= 0.262  # right_joint_1: the first action that faulted (4.4 rad/s)
    far[0, 13] = 0.0  # right gripper closing: by its rate from its measured 0.044, in range
    far[0, 0] = 5.0  # beyond the range: clipped to the range, then to the step
    action = limits_step({TransitionKey.ACTION: far})[TransitionKey.ACTION]
    max_step = np.array(cls.joint_steps(14, 50))
    delta = (action - state).numpy()[0]
    assert delta[8] == pytest.approx(-max_step[8], abs=1e-6)
    assert delta[0] == pytest.approx(max_step[0], abs=1e-6)
    assert action[0, 13].item() == pytest.approx(0.04)  # 0.044 - 0.0016, then the range
    assert np.all(np.abs(delta[:6]) <= max_step[:6] + 1e-6)
    # asked over the plugin's goal time, the held goal is within the joint's speed limit
    speed = abs(delta[8]) / (3 / 50)
    assert speed <= controller_limits()[1].velocity_max
    # an action near the state passes unchanged
    near = state + 0.01
    near[0, 6] = near[0, 13] = 0.04  # within the grippers' range
    kept = limits_step({TransitionKey.ACTION: near})[TransitionKey.ACTION]
    assert torch.allclose(kept, near)


def test_a_range_only_step_from_an_older_checkpoint_still_loads(tmp_path):
    torch = pytest.importorskip("torch")
    _lerobot_in_process()
    from lerobot.processor import ProcessorStepRegistry, TransitionKey

    cls.register()
    low, high = cls.controller_bounds(14)
    step = ProcessorStepRegistry.get(cls.REGISTRY_NAME)(low=low, high=high)
    action = torch.full((1, 14), 9.0)
    out = step({TransitionKey.ACTION: action})[TransitionKey.ACTION]
    assert torch.allclose(out, torch.tensor([high], dtype=out.dtype))
    assert step.get_config() == {"low": low, "high": high}


def test_gripper_goals_change_by_at_most_their_rate_from_one_action_to_the_next(built):
    torch, TransitionKey, measured_step, limits_step = built
    rate = cls.gripper_rates(14, 50)[6]
    assert rate == pytest.approx(0.9 * 0.0875 / 50)
    state = torch.tensor([[0.0, 0.2618, 0.2618, 0.0, 0.0, 0.0, 0.0125] * 2])

    def act(gripper: float, state=state):
        measured_step({TransitionKey.OBSERVATION: {"observation.state": state}})
        action = state.clone()
        action[0, 6] = action[0, 13] = gripper
        return limits_step({TransitionKey.ACTION: action})[TransitionKey.ACTION][0]

    # the first action of an episode starts from the measured width
    assert act(0.002)[6].item() == pytest.approx(0.0125 - rate)
    # then from the goal given last: a gripper squeezing the cube closes on to 2 mm
    goals = [act(0.002)[6].item() for _ in range(10)]
    assert goals[-1] == pytest.approx(0.002)
    assert all(abs(b - a) <= rate + 1e-7 for a, b in zip(goals, goals[1:], strict=False))
    # a jump of the policy's gripper (the wire fault: 6 mm in a period) moves by the rate
    assert act(0.008)[6].item() == pytest.approx(0.002 + rate)
    # a new episode (the arms back at the start, far from the last observation) starts over
    far = state.clone()
    far[0, 1] += 0.5
    measured_step({TransitionKey.OBSERVATION: {"observation.state": far}})
    limits_step({TransitionKey.ACTION: far.clone()})
    assert act(0.040)[6].item() == pytest.approx(0.0125 + rate)
    limits_step.reset()
    assert act(0.040)[6].item() == pytest.approx(0.0125 + rate)
    # a new episode where only the gripper jumped (an arm that hardly moved, its gripper
    # opened again by the env's reset; LeRobot's runners do not reset the steps): from the
    # measured width too, not from the last goal 33 mm away
    for _ in range(20):
        act(0.002)
    opened = state.clone()
    opened[0, 6] = opened[0, 13] = 0.035
    assert act(0.002, opened)[6].item() == pytest.approx(0.035 - rate)
