"""The pose encoder carried by a checkpoint's preprocessor (``eval.camera_pose_step``): how
it is written, what eval infers from it, and (where LeRobot is installed) that the step
replaces the env's object poses with the encoder's estimate from the camera."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from trossen_arm_mujoco.errors import UserError
from trossen_arm_mujoco.eval import camera_pose_step as cps
from trossen_arm_mujoco.eval.controller_limits_step import PREPROCESSOR_FILE
from trossen_arm_mujoco.eval.lerobot_policy import checkpoint_features


def _checkpoint(folder: Path) -> Path:
    """A checkpoint's config and preprocessor (no weights): the joints and the poses in."""
    folder.mkdir(parents=True)
    config = {
        "input_features": {
            "observation.state": {"type": "STATE", "shape": [14]},
            "observation.environment_state": {"type": "ENV", "shape": [7]},
        },
        "output_features": {"action": {"type": "ACTION", "shape": [14]}},
    }
    (folder / "config.json").write_text(json.dumps(config))
    pre = {
        "name": "policy_preprocessor",
        "steps": [
            {"registry_name": "to_batch_processor", "config": {}},
            {"registry_name": "normalizer_processor", "config": {}},
        ],
    }
    (folder / PREPROCESSOR_FILE).write_text(json.dumps(pre))
    return folder


def _encoder(path: Path) -> Path:
    pytest.importorskip("torch")
    pytest.importorskip("safetensors")
    from trossen_arm_mujoco.train.pose_encoder import _module, save_encoder

    save_encoder(_module(7), path)
    return path


def test_the_step_goes_before_the_normalizer_once_and_eval_sees_the_camera(tmp_path):
    ckpt = _checkpoint(tmp_path / "ckpt")
    assert checkpoint_features(ckpt)["sim_only"] is True  # the exact poses, before
    enc = _encoder(tmp_path / "enc.safetensors")
    cps.add_to_checkpoint(ckpt, enc, "cam_high")
    cps.add_to_checkpoint(ckpt, enc, "cam_high")  # again: replaced, not doubled
    steps = json.loads((ckpt / PREPROCESSOR_FILE).read_text())["steps"]
    assert [s["registry_name"] for s in steps] == [
        "to_batch_processor",
        cps.REGISTRY_NAME,
        "normalizer_processor",
    ]
    assert (ckpt / steps[1]["state_file"]).read_bytes() == enc.read_bytes()
    assert cps.camera_of(ckpt) == "cam_high"
    found = checkpoint_features(ckpt)
    assert found["sim_only"] is False and found["cam_names"] == ("cam_high",)
    assert found["pose_camera"] == "cam_high"


def test_bad_folders_and_encoders_are_one_line(tmp_path, capsys):
    with pytest.raises(UserError, match="no policy_preprocessor.json; give a LeRobot"):
        cps.add_to_checkpoint(tmp_path, tmp_path / "enc.safetensors", "cam_high")
    ckpt = _checkpoint(tmp_path / "ckpt")
    with pytest.raises(UserError, match="no pose encoder there; derive the dataset first"):
        cps.add_to_checkpoint(ckpt, tmp_path / "enc.safetensors", "cam_high")
    assert cps.camera_of(tmp_path / "nothing") is None
    assert cps.main([str(ckpt)]) == 2
    assert cps.main([str(ckpt), str(tmp_path / "none"), "cam_high"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("error: ") and "no pose encoder" in err[-1]


def _lerobot_in_process() -> None:
    """Like tests/eval/test_controller_limits_step.py: LeRobot in this process (py312)."""
    import importlib.util
    import os

    if importlib.util.find_spec("lerobot") is None and os.environ.get("TROSSEN_LEROBOT_PYTHON"):
        pytest.skip("run by the Python 3.12 leg of tools/run_tests.sh (marker py312)")
    pytest.importorskip("lerobot")


def test_the_step_replaces_the_envs_poses_with_the_encoders_estimate(tmp_path):
    torch = pytest.importorskip("torch")
    _lerobot_in_process()
    from lerobot.processor import DataProcessorPipeline, TransitionKey

    from trossen_arm_mujoco.train.pose_encoder import load_encoder

    ckpt = _checkpoint(tmp_path / "ckpt")
    (ckpt / PREPROCESSOR_FILE).write_text(json.dumps({"name": "policy_preprocessor", "steps": []}))
    enc = _encoder(tmp_path / "enc.safetensors")
    cps.add_to_checkpoint(ckpt, enc, "cam_high")
    cps.register()
    cps.register()  # twice is fine
    pipeline = DataProcessorPipeline.from_pretrained(str(ckpt), config_filename=PREPROCESSOR_FILE)
    image = torch.rand(1, 3, 24, 32)
    truth = torch.ones(1, 7)
    obs = {
        "observation.images.cam_high": image,
        "observation.environment_state": truth,
        "observation.state": torch.zeros(1, 14),
    }
    out = pipeline(obs)  # a batch in, a batch out (LeRobot's default converters)
    expected = load_encoder(enc)(image)
    np.testing.assert_allclose(
        out["observation.environment_state"].numpy(), expected.detach().numpy(), atol=1e-6
    )
    assert not torch.equal(out["observation.environment_state"], truth)
    step = pipeline.steps[0]
    with pytest.raises(ValueError, match="reads observation.images.cam_high"):
        step({TransitionKey.OBSERVATION: {"observation.state": torch.zeros(1, 14)}})
